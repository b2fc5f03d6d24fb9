"""The host's own lateness during `wiithrow check-driver`, measured, so that it is never taken for
the driver's.

A loaded host (other processes on its cores) wakes the check's thread late from its sleeps and
lets it wait for a CPU in the middle of a read: a state probe that read the arm once in 0.5 s, a
release timed 30 ms late, a command that started after the clock said it did. Those are the
host's, not the driver's. `HostWatch` is the clock the probes run on (the driver's, passed
through) that measures it: how late each sleep woke (`sleep(s)` took s + overshoot on the clock),
and, on Linux, how long the check's thread waited for a CPU (`/proc/thread-self/schedstat`, its
run-queue wait; real time only). A probe whose failure the host's lateness can explain says so
(`figures["host_late"]`, one line: what the host did that distorts which figure); `retried` then
runs it again, up to `HOST_TRIES` times, and a failure that stays the host's is reported as not
run, with how late the host was, never as the driver's failure.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from wiithrow.app.drivercheck.report import CheckResult
from wiithrow.clock import Clock, SystemClock

#: The host is late when it wakes the check's thread this much (s) after the time it asked for, or
#: makes it wait this long for a CPU: ten of the check's 0.5-ms polls, as long as a lag bound.
HOST_LATE_S = 0.005
#: A probe whose failure the host's lateness explains runs at most this many times.
HOST_TRIES = 3
#: Where Linux says how long this thread waited to run (ns: on the CPU, waiting for one, slices).
SCHEDSTAT = "/proc/thread-self/schedstat"


def cpu_wait_s() -> float | None:
    """How long (s) the calling thread has waited for a CPU since it started (Linux); None where the
    system does not say."""
    try:
        with open(SCHEDSTAT) as f:
            return int(f.read().split()[1]) * 1e-9
    except (OSError, ValueError, IndexError):
        return None


@dataclass(frozen=True)
class Lateness:
    """How late the host was over a stretch: the latest wake (s), how many sleeps woke
    `HOST_LATE_S` or more late of how many, and the thread's wait for a CPU (s; None: unknown)."""

    worst_wake_s: float
    late_wakes: int
    sleeps: int
    cpu_wait_s: float | None

    @property
    def late(self) -> bool:
        return self.worst_wake_s >= HOST_LATE_S or (self.cpu_wait_s or 0.0) >= HOST_LATE_S

    def line(self) -> str:
        """One line: how late the host was."""
        parts = [
            f"the check's thread woke up to {1e3 * self.worst_wake_s:.1f} ms late from its sleeps "
            f"({self.late_wakes} of {self.sleeps} {1e3 * HOST_LATE_S:.0f} ms or more late)"
        ]
        if self.cpu_wait_s is not None:
            parts.append(f"waited {1e3 * self.cpu_wait_s:.0f} ms for a CPU")
        return " and ".join(parts)


class HostWatch:
    """The driver's clock, passed through, measuring how late the host was (module docstring)."""

    def __init__(self, clock: Clock) -> None:
        self.clock = clock
        self.real_time = isinstance(clock, SystemClock)
        self._worst: list[float] = []  # the latest wake since each mark
        self._late = 0
        self._sleeps = 0

    def now(self) -> float:
        return self.clock.now()

    def sleep(self, seconds: float) -> None:
        before = self.clock.now()
        self.clock.sleep(seconds)
        over = self.clock.now() - before - max(seconds, 0.0)
        self._sleeps += 1
        if over >= HOST_LATE_S:
            self._late += 1
        for i, worst in enumerate(self._worst):
            if over > worst:
                self._worst[i] = over

    def mark(self) -> tuple[int, int, int, float | None]:
        """Start a stretch: pass what this returns to `since`."""
        self._worst.append(0.0)
        return len(self._worst) - 1, self._late, self._sleeps, cpu_wait_s() if self.real_time else None

    def since(self, mark: tuple[int, int, int, float | None]) -> Lateness:
        """How late the host was since `mark`."""
        index, late, sleeps, waited = mark
        now_waited = cpu_wait_s() if self.real_time else None
        cpu = None if waited is None or now_waited is None else now_waited - waited
        return Lateness(self._worst[index], self._late - late, self._sleeps - sleeps, cpu)


def host_mark(clock: Clock) -> Any:
    """A mark of `clock` to measure from (`host_lateness`), None when it is not a `HostWatch`."""
    return clock.mark() if isinstance(clock, HostWatch) else None


def host_lateness(clock: Clock, mark: Any) -> Lateness | None:
    """How late the host was since `mark` (`host_mark`), None when the probes do not run on a
    `HostWatch`."""
    return clock.since(mark) if isinstance(clock, HostWatch) and mark is not None else None


def retried(name: str, probe: Callable[[], CheckResult], watch: HostWatch, say: Callable[[str], None]) -> CheckResult:
    """`probe()`, run again while it fails only as the host's lateness explains (its
    `figures["host_late"]`), at most `HOST_TRIES` times; then not run, saying how late the host
    was (module docstring)."""
    result = probe()
    lateness = []
    for attempt in range(1, HOST_TRIES + 1):
        if result.status != "fail" or not result.figures.get("host_late"):
            if attempt > 1:
                result.figures["host_tries"] = attempt
            return result
        lateness.append(str(result.figures["host_late"]))
        if attempt == HOST_TRIES:
            break
        say(f"{name}: the host was late ({lateness[-1]}): once more")
        result = probe()
    return CheckResult(
        name,
        "not run",
        f"the host was late in {HOST_TRIES} tries ({lateness[-1]}); the figures it distorts cannot judge the "
        "driver: run the check on a quieter host",
        {**result.figures, "host_tries": HOST_TRIES},
        result.bounds,
    )
