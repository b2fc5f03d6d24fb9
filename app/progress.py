"""Progress bars, on a terminal only.

`progress_bar(...)` is a tqdm bar on stderr when stderr is a terminal and nothing otherwise: a
log file or a pipe would collect every redraw of it. `show=False` turns it off anyway (tests, a
caller with a progress display of its own).
"""

from __future__ import annotations

from collections.abc import Iterable
from typing import Any

from tqdm import tqdm


def progress_bar(iterable: Iterable[Any] | None = None, *, show: bool = True, **options: Any) -> tqdm:
    """A tqdm bar (same options) shown only when `show` and stderr is a terminal."""
    return tqdm(iterable, disable=None if show else True, **options)
