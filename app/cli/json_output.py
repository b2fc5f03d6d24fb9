"""`--json`: exactly one strict JSON document on standard output, nothing else.

While a command given `--json` runs, `wiithrow.app.cli.main` points `sys.stdout` at stderr
(`json_mode`), so whatever else writes to it (a library's banner: viser's, on starting a server;
a progress line) lands on stderr; `emit(document)` writes the document, once, to the real stdout.
The document is strict JSON (`vision.files.strict_json`): NaN and infinities are null, numpy
numbers and arrays plain numbers and lists, so `json.loads(..., parse_constant=...)` refusing
NaN reads it.
"""

from __future__ import annotations

import contextlib
import sys
from collections.abc import Iterator
from typing import IO, Any

from wiithrow.vision.files import dumps_strict

_stdout: list[IO[str]] = []  # the real standard output while a --json command runs
_emitted: list[bool] = []


@contextlib.contextmanager
def json_mode() -> Iterator[None]:
    """Run a --json command: stdout goes to stderr, except what `emit` writes."""
    real = sys.stdout
    _stdout.append(real)
    _emitted.append(False)
    try:
        with contextlib.redirect_stdout(sys.stderr):
            yield
    finally:
        _stdout.pop()
        _emitted.pop()


def emit(document: Any) -> None:
    """Write `document` as strict JSON to the real standard output (once per command)."""
    if _emitted:
        if _emitted[-1]:
            raise RuntimeError("a --json command printed a second JSON document")
        _emitted[-1] = True
    out = _stdout[-1] if _stdout else sys.stdout
    out.write(dumps_strict(document, indent=2) + "\n")
    out.flush()
