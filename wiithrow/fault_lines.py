"""One line on stderr per distinct fault of a loop that goes on: `FaultLines`.

A thread's loop (the dashboard's refresh, the session's rig loop, a recording's flusher, a
publisher's writer) catches what it calls, tells it here and keeps running. What it tells is one
line, `wiithrow <where>: <Type>: <message> (...goes on)`, the first time each distinct fault (type
and message) happens: a fault that repeats every tick is one line, not a line per tick nor a
traceback. At most `MAX_DISTINCT_FAULTS` distinct lines per loop, then one line that says the rest
are counted (`count`); a loop that shows its faults elsewhere (a status, a notification) reads
`last`.
"""

from __future__ import annotations

import sys
import threading
from collections.abc import Iterator
from contextlib import contextmanager

#: Distinct fault lines one loop prints; a fault whose message changes every time (a timestamp in
#: it) would otherwise be a line per tick. Ten is more than the faults one cause produces.
MAX_DISTINCT_FAULTS = 10


def describe(exc: BaseException) -> str:
    """`exc` in one line: its type and the first line of its message."""
    text = str(exc).strip().splitlines()
    return f"{type(exc).__name__}: {text[0]}" if text and text[0] else type(exc).__name__


class FaultLines:
    """The faults of the loop `where` (module docstring)."""

    def __init__(self, where: str) -> None:
        self.where = where
        self.count = 0
        self.last: str | None = None
        self._seen: set[str] = set()
        self._lock = threading.Lock()

    def report(self, exc: BaseException, consequence: str = "it goes on") -> bool:
        """Count `exc`; print its one line if it is new (and the limit not reached). Whether it printed."""
        return self.tell(describe(exc), consequence)

    def tell(self, text: str, consequence: str = "it goes on") -> bool:
        """`report` for a fault already put in words."""
        with self._lock:
            self.count += 1
            self.last = text
            if text in self._seen or len(self._seen) > MAX_DISTINCT_FAULTS:
                return False
            self._seen.add(text)
            if len(self._seen) > MAX_DISTINCT_FAULTS:
                line = f"wiithrow {self.where}: more faults than {MAX_DISTINCT_FAULTS} kinds: counted, not shown"
            else:
                line = f"wiithrow {self.where}: {text} ({consequence})"
        try:
            print(line, file=sys.stderr, flush=True)
        except (OSError, ValueError):  # no stderr left (closed at exit): the count stays
            pass
        return True

    @contextmanager
    def guard(self, consequence: str = "it goes on") -> Iterator[None]:
        """Run the block; an Exception in it is reported (`report`) and ends only the block."""
        try:
            yield
        except Exception as exc:
            self.report(exc, consequence)
