"""Rows streamed to standard output (`wiithrow track`, `wiithrow listen`) when it can fail.

`StdoutRows` writes to `sys.stdout` and is flushed after each batch of rows: a write that fails
(a full disk behind `> file`: ENOSPC, a quota, an I/O error) becomes one line, an `AppError`
saying how many rows went out, instead of an OSError traceback, and what is still in the buffer
goes to /dev/null instead of a second traceback at exit. A reader that went away (`| head`) stays
a BrokenPipeError: `wiithrow.app.cli.main`'s quiet exit. Rows to a file go through
`wiithrow.vision.outputs.StagedFile`, which keeps the complete lines written when the disk fills.
"""

from __future__ import annotations

import contextlib
import os
import sys
from collections.abc import Callable
from typing import Any, Protocol

from wiithrow.app.errors import AppError


class Rows(Protocol):
    """Where rows go: a text file (`StagedFile.handle`), standard output (`StdoutRows`)."""

    def write(self, text: str, /) -> int: ...

    def flush(self) -> None: ...


class StdoutRows:
    """Standard output for rows, flushed after each frame (`flush`): a write that fails (a full disk
    behind `> file`) is an AppError saying how many rows went out, and what stays in the buffer
    goes to /dev/null instead of a traceback at exit; a reader that went away (`| head`) stays a
    BrokenPipeError, `main`'s quiet exit."""

    def __init__(self) -> None:
        self.pending = 0
        self.written = 0

    def write(self, text: str) -> int:
        self.pending += text.count("\n")
        return self._guard(lambda: sys.stdout.write(text))

    def flush(self) -> None:
        self._guard(sys.stdout.flush)
        self.written, self.pending = self.written + self.pending, 0

    def _guard(self, operation: Callable[[], Any]) -> Any:
        try:
            return operation()
        except BrokenPipeError:
            raise
        except OSError as exc:
            with contextlib.suppress(OSError, ValueError, AttributeError):  # not a stream on a file descriptor
                target = sys.stdout.fileno()
                devnull = os.open(os.devnull, os.O_WRONLY)
                try:
                    os.dup2(devnull, target)
                finally:
                    os.close(devnull)
            raise AppError(
                f"cannot write more to standard output ({exc.strerror or exc}): the {self.written} rows "
                "before it were written"
            ) from None
