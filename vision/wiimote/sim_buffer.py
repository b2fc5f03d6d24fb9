"""The simulated remote's HID buffer: reports due at their times, read oldest first, bounded.

Everything a `SimulatedWiimote` sends (data reports at their 10 ms ticks, replies after the
response latency) is scheduled here with the time it is due on the clock. Once due it moves into
a buffer of `size` reports (64, like Linux hidraw) that `read` empties oldest first; when the
reader falls behind, the oldest buffered report is dropped (as hidapi's libusb backend does).
Reports due at the same time keep the order they were scheduled in.
"""

from __future__ import annotations

import heapq
import math
from collections import deque

#: Slack (seconds) when comparing a due time with the clock.
EPS = 1e-9


class HidBuffer:
    """Scheduled reports and the bounded buffer of the due ones (see the module docstring)."""

    def __init__(self, size: int) -> None:
        if size < 1:
            raise ValueError("buffer_size must be at least 1")
        self.size = int(size)
        self._pending: list[tuple[float, int, bytes]] = []  # heap of (due time, order, report)
        self._buffer: deque[bytes] = deque()
        self._order = 0

    def schedule(self, due: float, report: bytes) -> None:
        """Send `report` at time `due`."""
        self._order += 1
        heapq.heappush(self._pending, (due, self._order, report))

    def deliver(self, now: float) -> int:
        """Move the reports due by `now` into the buffer; returns how many old ones it dropped."""
        dropped = 0
        while self._pending and self._pending[0][0] <= now + EPS:
            _, _, report = heapq.heappop(self._pending)
            if len(self._buffer) >= self.size:
                self._buffer.popleft()
                dropped += 1
            self._buffer.append(report)
        return dropped

    def pop(self) -> bytes | None:
        """The oldest buffered report, or None when the buffer is empty."""
        return self._buffer.popleft() if self._buffer else None

    def pop_all(self) -> list[bytes]:
        """Every buffered report, oldest first (the buffer is left empty)."""
        out = list(self._buffer)
        self._buffer.clear()
        return out

    @property
    def buffered(self) -> int:
        """How many due reports wait to be read."""
        return len(self._buffer)

    def next_due(self) -> float:
        """When the next scheduled report is due (inf when none is)."""
        return self._pending[0][0] if self._pending else math.inf

    def clear(self) -> None:
        """Forget every scheduled and buffered report."""
        self._pending.clear()
        self._buffer.clear()
