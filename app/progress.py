"""Progress bars, on a terminal only.

`progress_bar(...)` is a tqdm bar on stderr when stderr is a terminal and nothing otherwise: a
log file or a pipe would collect every redraw of it. `show=False` turns it off anyway (tests, a
caller with a progress display of its own).

A terminal that reports no height (a pty nobody sized, `script` without a terminal, some serial
consoles: rows 0) made tqdm hide every bar, as if each were nested beyond the screen's bottom; such
a terminal is given tqdm's own fallback height (`FALLBACK_ROWS`).
"""

from __future__ import annotations

import os
import sys
from collections.abc import Iterable
from typing import Any

from tqdm import tqdm

#: The height (lines) of a terminal that reports none: tqdm's fallback.
FALLBACK_ROWS = 20


def _rows() -> int:
    """stderr's terminal height, `FALLBACK_ROWS` when it reports none (or is no terminal)."""
    try:
        rows = os.get_terminal_size(sys.stderr.fileno()).lines
    except (OSError, ValueError, AttributeError):  # no terminal, or a stderr without a descriptor
        return FALLBACK_ROWS
    return rows or FALLBACK_ROWS


def progress_bar(iterable: Iterable[Any] | None = None, *, show: bool = True, **options: Any) -> tqdm:
    """A tqdm bar (same options) shown only when `show` and stderr is a terminal."""
    options.setdefault("nrows", _rows())
    return tqdm(iterable, disable=None if show else True, **options)
