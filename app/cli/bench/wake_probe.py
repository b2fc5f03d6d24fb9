"""`WakeProbe`: how late this machine lets a thread run when it asked to, measured beside a benchmark.

What `bench latency` reports as each configuration's `machine_wake`: the floor under its own
figures. A latency from a report's read to a consumer includes every moment the tracking's threads
(or the publisher's process) wanted a core and did not get one, and on a virtual machine those
moments are the host's: a 2-core VM whose benchmark showed a p99 of 1.2 ms one day showed 2-4 ms
the next with nothing of ours changed. This probe says, for the very seconds a configuration was
measured, how late the machine woke a thread that had asked to run.

The method is `cyclictest`'s (rt-tests, the usual wake-up latency test of real-time Linux), in a
small process of its own: it sleeps until deadlines `INTERVAL_S` apart on CLOCK_MONOTONIC
(`select` with the time left: the kernel's high-resolution timer, plus its timer slack, 50 us by
default for a normal thread) and records how late each wake came (`now - deadline`, which also
holds a few microseconds of this interpreter's own). A wake later than the next deadline skips the
deadlines it missed (as `web/throttle.Ticker` does) rather than counting the catch-up wakes. The
process runs at the benchmark's priority and shares no interpreter with it; it costs about 1% of a
core (a thousand wakes a second of a few microseconds).

The protocol (stdin/stdout, one line each): the probe says `ready`, waits for a line (`begin`),
measures until its stdin closes (`end`), then prints its figures as one JSON line and exits. This
file imports only the standard library: it runs as a script (`python wake_probe.py`), started in
milliseconds and importing nothing of the benchmark's.
"""

from __future__ import annotations

import json
import math
import select
import subprocess
import sys
import time
from pathlib import Path
from typing import IO, Any

#: Seconds between the probe's deadlines (cyclictest's default interval, 1,000 us).
INTERVAL_S = 0.001
READY = "ready"
#: How long `begin` waits for the probe to say it is ready, and `end` for its figures (s).
ANSWER_S = 30.0


def percentile(ordered: list[float], q: float) -> float:
    """The q-th percentile of ascending `ordered`, interpolated linearly between the two nearest
    ranks (numpy's default method): position (n - 1) q / 100."""
    position = (len(ordered) - 1) * q / 100.0
    low = math.floor(position)
    high = min(low + 1, len(ordered) - 1)
    return ordered[low] + (ordered[high] - ordered[low]) * (position - low)


def summary(lateness_s: list[float]) -> dict[str, float | int]:
    """count, p50, p99 and max of the wakes' lateness, in ms (as `bench latency` gives its own)."""
    if not lateness_s:
        return {"count": 0, "p50_ms": float("nan"), "p99_ms": float("nan"), "max_ms": float("nan")}
    ms = sorted(1e3 * value for value in lateness_s)
    return {"count": len(ms), "p50_ms": percentile(ms, 50), "p99_ms": percentile(ms, 99), "max_ms": ms[-1]}


def measure(stop: IO[str], interval_s: float = INTERVAL_S) -> list[float]:
    """Sleep to deadlines `interval_s` apart until `stop` is readable (a line or its end); how late
    each wake at a deadline came (s)."""
    lateness: list[float] = []
    deadline = time.monotonic() + interval_s
    while True:
        readable, _, _ = select.select([stop], [], [], max(0.0, deadline - time.monotonic()))
        now = time.monotonic()
        if readable:
            return lateness
        lateness.append(now - deadline)
        deadline += interval_s
        if deadline <= now:  # late past the next deadline: skip the ones missed
            deadline = now + interval_s


def _probe() -> int:
    """The probe's side of the protocol (module docstring)."""
    print(READY, flush=True)
    if not sys.stdin.readline():  # closed before `begin`: nothing to measure
        return 0
    lateness = measure(sys.stdin)
    print(json.dumps(summary(lateness)), flush=True)
    return 0


class WakeProbe:
    """The probe process beside a measurement: `begin()` when the measured seconds start, `end()`
    when they stop (its figures: `summary`'s). `close()` ends it at any point."""

    def __init__(self) -> None:
        self._child = subprocess.Popen(
            [sys.executable, str(Path(__file__).resolve())],
            stdin=subprocess.PIPE,
            stdout=subprocess.PIPE,
            text=True,
        )

    def _line(self) -> str:
        out = self._child.stdout
        assert out is not None
        if not select.select([out], [], [], ANSWER_S)[0]:
            self.close()
            raise RuntimeError(f"the wake probe said nothing in {ANSWER_S:.0f} s")
        return out.readline().strip()

    def begin(self) -> None:
        """Start measuring (once the probe is ready)."""
        said = self._line()
        if said != READY:
            self.close()
            raise RuntimeError(f"the wake probe did not start: it said {said!r}")
        assert self._child.stdin is not None
        self._child.stdin.write("begin\n")
        self._child.stdin.flush()

    def end(self) -> dict[str, Any]:
        """Stop measuring; the wakes' figures (count, p50_ms, p99_ms, max_ms)."""
        assert self._child.stdin is not None
        self._child.stdin.close()
        figures: dict[str, Any] = json.loads(self._line())
        self._child.wait(ANSWER_S)
        return figures

    def close(self) -> None:
        if self._child.poll() is None:
            self._child.kill()
            self._child.wait()
        for stream in (self._child.stdin, self._child.stdout):
            if stream is not None and not stream.closed:
                stream.close()


if __name__ == "__main__":
    sys.exit(_probe())
