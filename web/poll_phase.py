"""`PollPhase`: the dashboard refreshes between two polls of the rig, never in the middle of one.

The rig's thread polls every 10 ms (read the remotes, decode, synchronise, track, tell the
listeners: recorder, publisher, session); at the poll's end the writer processes (Zenoh, ROS 2,
Foxglove) are woken to put what it tracked (`wiithrow.listeners.batch`); a refresh of the dashboard
is about a millisecond of Python on a thread of the rig's process (17 ms of CPU a second at 20 Hz
with no browser). A refresh at an arbitrary moment of its 20 Hz tick competes now and then with
the poll for the interpreter and with the writers for the two cores.

So the refresh waits, after its tick, for the end of the rig's next poll (the source's `Flushed`
event, the last thing the local rig tells in a poll) and then `after_s` more (3 ms), and draws in
the quiet between two polls: the rig's thread is asleep, and the writer processes (Zenoh, ROS 2,
Foxglove), woken at the end of the poll (`wiithrow.listeners.batch`), have put their frames. A
refresh started right at the poll's end took a core from the Zenoh writer just woken: its p99 rose
from 1.2-1.4 ms to 2.1-2.2 ms (two alternate pairs of 30-s runs). The tick keeps the rate; this
only moves each refresh to a fixed point of the poll period, at most `timeout_s` + `after_s`
later (a rig that does not poll, a stopped session: the refresh goes ahead after the timeout). A
side effect the operator sees: each refresh draws a frame about 3 ms old, not up to 10 ms
(`bench latency`'s dashboard figure, p50 / p99: 4.3-4.5 / 5.4-5.5 ms against 5.5-6.0 / 12-12.5).

Only on the system clock: on a simulated clock (tests, headless runs) the world runs as fast as
the CPU allows and has no poll period to align with, and a listener would cost it the reads the
rig skips when no one listens (`wiithrow.app.rig.waiting`).
"""

from __future__ import annotations

import threading
import time

from wiithrow.app.rig.events import Flushed, RigEvent
from wiithrow.app.rig.source import MarkerSource
from wiithrow.clock import SystemClock

#: How long (s) a refresh waits at most for the end of the rig's next poll: one 10 ms poll period
#: and a little more.
POLL_WAIT_S = 0.012
#: How long (s) after a poll's end a refresh starts: after the writer processes woken then (their
#: put: 0.3-0.7 ms), well before the next poll (10 ms after the last).
AFTER_POLL_S = 0.003


class PollPhase:
    """Tells a waiting thread when the source's next poll has ended (`wait`), see the module docstring."""

    def __init__(self, source: MarkerSource, *, timeout_s: float = POLL_WAIT_S, after_s: float = AFTER_POLL_S) -> None:
        if not timeout_s > 0:
            raise ValueError(f"timeout_s must be > 0, got {timeout_s}")
        if not after_s >= 0:
            raise ValueError(f"after_s must be >= 0, got {after_s}")
        self.timeout_s = float(timeout_s)
        self.after_s = float(after_s)
        self._ended = threading.Event()
        #: Waits that saw a poll end, and waits that gave up after `timeout_s`.
        self.aligned = 0
        self.timed_out = 0
        self._unsubscribe = source.subscribe(self._on_event) if isinstance(source.clock, SystemClock) else None

    @property
    def following(self) -> bool:
        """Whether the source is followed (False on a simulated clock: `wait` returns at once)."""
        return self._unsubscribe is not None

    def _on_event(self, event: RigEvent) -> None:  # the rig's thread, under its lock: nothing slow
        if isinstance(event, Flushed):
            self._ended.set()

    def wait(self) -> bool:
        """Until `after_s` after the source's next poll ended (True), or `timeout_s` without one
        (False); at once when the source is not followed (False)."""
        if self._unsubscribe is None:
            return False
        self._ended.clear()
        if self._ended.wait(self.timeout_s):
            self.aligned += 1
            if self.after_s:
                time.sleep(self.after_s)
            return True
        self.timed_out += 1
        return False

    def close(self) -> None:
        """Stop following the source (idempotent)."""
        unsubscribe, self._unsubscribe = self._unsubscribe, None
        if unsubscribe is not None:
            unsubscribe()
