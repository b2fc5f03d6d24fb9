"""Pacing and measuring the dashboard's updates, so that drawing never slows the tracking loop.

Owns four small tools, and a way to read a thread's CPU time:

* `Ticker`: a fixed-rate loop clock without drift (the scene refreshes at 20 Hz, not as fast as
  the session changes: one batched update per tick);
* `Every`: "at most every `period_s`" for the slower parts of an update (camera images);
* `CostMeter`: the cost of each update (wall time and the updating thread's CPU time), kept for
  the last `window` updates, which `wiithrow bench dashboard` reports as cost per update and per
  tracking frame;
* `AdaptiveRate`: the refresh rate that keeps the dashboard's CPU time (refreshing, plus sending to
  every client) within a budget per tracking frame: at most `max_hz`, lower when many clients make
  each update dearer, never below `min_hz`.

`thread_cpu_s` reads a thread's CPU time; `sender_thread` finds viser's event-loop thread, which
serialises and sends the messages (the other half of the dashboard's cost).

`SwitchInterval` shortens the interpreter's switch interval while a dashboard serves. A thread
that wants the interpreter lock while another holds it waits for the holder to let go, and asks
it to after `sys.getswitchinterval()` (5 ms by default). The dashboard's refresh and viser's
event loop hold it for a millisecond or more at a time (building, serialising messages), so the
rig's thread, woken for its next poll, and the publisher's thread, woken by a tracked frame,
could wait up to 5 ms for them: the p99 of a frame's delivery with a dashboard attached was
2.6 ms (`wiithrow bench latency`). At `SWITCH_INTERVAL_S` (0.5 ms) a waiting thread gets the lock
within about half a millisecond (a C call that keeps it, a large `msgpack` or `numpy` step,
still runs to its end). The cost: while two threads want the interpreter at once, it changes
hands up to ten times as often (a few microseconds each); when one thread runs alone it never
switches, so a process that is mostly waiting (the rig at 100 Hz, the refresh at 20 Hz) pays
next to nothing.
"""

from __future__ import annotations

import sys
import threading
import time
from collections import deque
from dataclasses import dataclass

import numpy as np
import viser

#: The interpreter's switch interval (s) while a dashboard serves (see the module docstring).
SWITCH_INTERVAL_S = 0.0005


class SwitchInterval:
    """Sets the interpreter's switch interval to `interval_s` on `apply()` and puts back the one
    it found on `restore()` (if no one changed it meanwhile): it is the process's, not ours."""

    def __init__(self, interval_s: float = SWITCH_INTERVAL_S) -> None:
        if not interval_s > 0:
            raise ValueError(f"interval_s must be > 0, got {interval_s}")
        self.interval_s = float(interval_s)
        self._before: float | None = None

    def apply(self) -> None:
        if self._before is None:
            self._before = sys.getswitchinterval()
            sys.setswitchinterval(self.interval_s)

    def restore(self) -> None:
        before, self._before = self._before, None
        if before is not None and abs(sys.getswitchinterval() - self.interval_s) < 1e-7:  # (kept in µs)
            sys.setswitchinterval(before)


class Ticker:
    """Ticks every `period_s` on the monotonic clock; a late tick is skipped, not made up."""

    def __init__(self, rate_hz: float) -> None:
        self._next = time.monotonic()
        self.set_rate(rate_hz)

    def set_rate(self, rate_hz: float) -> None:
        if not rate_hz > 0:
            raise ValueError(f"rate_hz must be > 0, got {rate_hz}")
        self.period_s = 1.0 / float(rate_hz)

    def wait(self, stop: threading.Event) -> bool:
        """Sleep until the next tick; False if `stop` was set meanwhile."""
        self._next += self.period_s
        now = time.monotonic()
        if self._next < now:  # fell behind (a long update): start again from now
            self._next = now
        return not stop.wait(max(0.0, self._next - now))


class Every:
    """True at most once per `period_s` (on the monotonic clock)."""

    def __init__(self, period_s: float) -> None:
        self.period_s = float(period_s)
        self._last = -np.inf

    def due(self, now: float | None = None) -> bool:
        now = time.monotonic() if now is None else now
        if now - self._last >= self.period_s:
            self._last = now
            return True
        return False


@dataclass(frozen=True)
class CostSummary:
    """Cost of the last `updates` updates, in milliseconds per update."""

    updates: int
    wall_mean_ms: float
    wall_p50_ms: float
    wall_p99_ms: float
    cpu_mean_ms: float

    def to_dict(self) -> dict[str, float]:
        return {
            "updates": self.updates,
            "wall_mean_ms": self.wall_mean_ms,
            "wall_p50_ms": self.wall_p50_ms,
            "wall_p99_ms": self.wall_p99_ms,
            "cpu_mean_ms": self.cpu_mean_ms,
        }


class CostMeter:
    """Times updates: `with meter.measure(): ...`; `summary()` over the last `window` of them."""

    def __init__(self, window: int = 2000) -> None:
        self._wall: deque[float] = deque(maxlen=window)
        self._cpu: deque[float] = deque(maxlen=window)
        self._lock = threading.Lock()
        self.count = 0

        self.total_cpu_s = 0.0

    def record(self, wall_s: float, cpu_s: float) -> None:
        with self._lock:
            self._wall.append(wall_s)
            self._cpu.append(cpu_s)
            self.count += 1
            self.total_cpu_s += cpu_s

    def measure(self) -> _Measurement:
        return _Measurement(self)

    def reset(self) -> None:
        with self._lock:
            self._wall.clear()
            self._cpu.clear()

    def summary(self) -> CostSummary:
        with self._lock:
            wall = 1e3 * np.array(self._wall)
            cpu = 1e3 * np.array(self._cpu)
        if wall.size == 0:
            return CostSummary(0, float("nan"), float("nan"), float("nan"), float("nan"))
        return CostSummary(
            int(wall.size),
            float(wall.mean()),
            float(np.percentile(wall, 50)),
            float(np.percentile(wall, 99)),
            float(cpu.mean()),
        )


class _Measurement:
    def __init__(self, meter: CostMeter) -> None:
        self.meter = meter

    def __enter__(self) -> _Measurement:
        self._wall = time.perf_counter()
        self._cpu = time.thread_time()
        return self

    def __exit__(self, *exc: object) -> None:
        self.meter.record(time.perf_counter() - self._wall, time.thread_time() - self._cpu)


class AdaptiveRate:
    """The refresh rate (Hz) that spends at most `budget_ms` of CPU per tracking frame.

    With tracking at `tracking_hz`, the budget is a CPU share of budget_ms * tracking_hz / 1000
    (1 ms per 10 ms frame: 10 % of a core). `observe(cpu_s, updates)` takes what the last updates
    cost, all threads the dashboard keeps busy included, and moves the rate halfway towards
    budget share / cost per update, within [min_hz, max_hz].
    """

    def __init__(
        self, max_hz: float, *, min_hz: float = 5.0, budget_ms: float = 1.0, tracking_hz: float = 100.0
    ) -> None:
        self.max_hz, self.min_hz = float(max_hz), float(min(min_hz, max_hz))
        self.share = budget_ms * tracking_hz / 1000.0
        self.rate_hz = self.max_hz

    def observe(self, cpu_s: float, updates: int) -> float:
        if updates > 0 and cpu_s > 0:
            wanted = self.share / (cpu_s / updates)
            self.rate_hz = float(np.clip(0.5 * (self.rate_hz + wanted), self.min_hz, self.max_hz))
        return self.rate_hz


def sender_thread(server: viser.ViserServer) -> threading.Thread | None:
    """viser's event-loop thread, which serialises, compresses and sends the messages once per
    client (a private attribute of viser 1.1: None if a later viser moved it)."""
    thread = getattr(getattr(server, "_websock_server", None), "_server_thread", None)
    return thread if isinstance(thread, threading.Thread) and thread.ident is not None else None


def thread_cpu_s(thread: threading.Thread | None) -> float:
    """CPU time (s) a running thread has used; 0 when unknown."""
    if thread is None or thread.ident is None or not hasattr(time, "pthread_getcpuclockid"):
        return 0.0
    try:
        return time.clock_gettime(time.pthread_getcpuclockid(thread.ident))
    except (OSError, ValueError):
        return 0.0
