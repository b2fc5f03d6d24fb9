"""The hand's probe of `wiithrow check-driver`: `probe_hand`, through the `Gripper` interface only,
read every `bounds.POLL_S` on the clock the driver was given.

What a throw needs of a hand is that it lets the ball go when the release comes, the same way
every time. `HAND_CYCLES` times, in the way a throw releases (`open_at(t_r)` with
`t_r = now + HAND_SCHEDULE_LEAD_S` for a hand that schedules its open, `ScheduledOpen`; else
`open()` called at t_r):

1. from the hand open, its jaws at rest, `close()`, then read the hand until its jaws settled
   (`wiithrow.robot.hand_timing.JawsSettle`, as the grip wait and `measure_close_time` time it:
   until it says it holds, or its jaws moved and stopped). Its close time: from `close()` until
   then;
2. the release at t_r, then read the hand until it is open: the time from t_r until the jaws
   start to part (the opening `HAND_PART_OPENING` above where they closed), until the ball is
   free (`holding` turns False, on a hand that held after the close), and until the hand is open
   (opening >= `HAND_OPEN_FRACTION`). Each is timed by the timestamp of the state that first
   showed it (or the clock when it was read, if that stamp is not between the two reads).

Judged: the jaws' parting and the ball's freeing (median, latest, jitter: the standard deviation
over the cycles but the latest, which is bounded on its own), against `HAND_RELEASE_MAX_S`, `HAND_RELEASE_WORST_MAX_S` and
`HAND_JITTER_MAX_S`; the close and open times against what the settings state (`hand_close_s`,
`hand_open_s`: every one within it), not judged where they state none. A hand that cannot tell
whether it holds is judged on its jaws alone.

The host's lateness is not the hand's. A parting (or a freeing) is timed only when the host read
the hand within `HAND_READ_GAP_MAX_S` of its read before, or the state's timestamp is within
that of it, and a host-timed `open()` only when it returned within that of t_r: a host that read
later cannot say when the jaws moved, and the cycle is done again (`host_late_cycles`), at most
`HAND_HOST_LATE_CYCLES` times; beyond, the check is not run and says how late the host was. (A
hand whose state is sampled coarsely is read on time: its own quantisation counts.)

A hand without the scheduled open is host-timed: the host calls `open()` when the release time
comes, so a host stalled then (a camera read, a flood of network frames) opens it late. The check
judges such a hand on its timing but warns (`HOST_TIMED_WARNING`; `schedules_open` in the
figures): a throw refuses to release later than its bound (`RELEASE_LATE_BOUND_S` in
`wiithrow.app.throws.execution`), ending before the release with the ball kept, and a driver with
`open_at` removes the risk.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from wiithrow.app.drivercheck import bounds
from wiithrow.app.drivercheck.report import CheckResult, judged
from wiithrow.clock import Clock
from wiithrow.robot.gripper import Gripper, GripperState, ScheduledOpen
from wiithrow.robot.hand_timing import JAWS_STILL_OPENING, JAWS_STILL_S, JawsSettle

#: The hand check's warning for a hand without `open_at` (module docstring).
HOST_TIMED_WARNING = (
    "host-timed hand: it has no scheduled open (open_at), so the host times its release and a host "
    "stalled at the release opens it late; a throw then refuses to release later than its bound "
    "(RELEASE_LATE_BOUND_S, wiithrow.app.throws.execution) and ends with the ball kept; a driver with "
    "open_at (wiithrow.robot.gripper.ScheduledOpen) opens on the hand's own clock and removes the risk"
)


class HostLate(Exception):
    """The host read the hand too late to time this cycle (the gap, s)."""

    def __init__(self, gap_s: float) -> None:
        super().__init__(f"read {1e3 * gap_s:.1f} ms after the read before")
        self.gap_s = gap_s


class HandFault(Exception):
    """The hand did not do what the cycle waits for (one line)."""


@dataclass
class Cycles:
    """What the cycles measured (s); NaN where a cycle could not tell."""

    close: list[float] = field(default_factory=list)
    part: list[float] = field(default_factory=list)
    free: list[float] = field(default_factory=list)
    open: list[float] = field(default_factory=list)
    host_late: list[float] = field(default_factory=list)  # the gaps of the cycles done again


@dataclass(frozen=True)
class HandTimes:
    """The settings' close and open times of the hand (s; 0: not stated)."""

    close_s: float = 0.0
    open_s: float = 0.0

    def timeout(self, stated: float) -> float:
        return max(bounds.HAND_TIMEOUT_S, 2.0 * stated)


def _stamp(state: GripperState, previous: float, now: float) -> float:
    """When a state showed what it shows: its timestamp where it lies between the two reads, else
    the clock when it was read."""
    return float(state.t) if previous <= state.t <= now else now


def _settle(gripper: Gripper, clock: Clock, settle: JawsSettle, told: float, timeout: float) -> GripperState:
    """Read the hand until its jaws settled (`JawsSettle`); the last state. HandFault after
    `timeout` s from `told`."""
    while True:
        state = gripper.state()
        if settle.feed(state):
            return state
        if clock.now() - told > timeout:
            raise HandFault(f"opening {state.opening:.2f}")
        clock.sleep(bounds.POLL_S)


def _close(gripper: Gripper, clock: Clock, times: HandTimes) -> tuple[float, GripperState]:
    """`close()` and read until closed (module docstring); (close time, the closed state)."""
    settle = JawsSettle(gripper.state(), closing=True)
    told = clock.now()
    gripper.close()
    timeout = times.timeout(times.close_s)
    try:
        state = _settle(gripper, clock, settle, told, timeout)
    except HandFault as fault:
        hint = "" if times.close_s else "; a slower hand states hand_close_s in the settings"
        raise HandFault(f"did not close within {timeout:.1f} s of close() ({fault}{hint})") from None
    assert settle.settled_at is not None  # settled
    return max(0.0, settle.settled_at - told), state


def _release(
    gripper: Gripper, clock: Clock, closed: GripperState, scheduled: bool, times: HandTimes
) -> tuple[float, float, float]:
    """The release (module docstring); (to the jaws parting, to the ball free or NaN, to open)."""
    t_r = clock.now()
    if scheduled and isinstance(gripper, ScheduledOpen):
        t_r += bounds.HAND_SCHEDULE_LEAD_S
        gripper.open_at(t_r)
    else:
        gripper.open()
        returned = clock.now()
        if returned - t_r > bounds.HAND_READ_GAP_MAX_S:
            raise HostLate(returned - t_r)
    part_at = free_at = open_at = float("nan")
    tells = bool(closed.holding)
    parting = float(closed.opening) + bounds.HAND_PART_OPENING
    timeout = times.timeout(times.open_s)
    previous = clock.now()  # when the host last read the hand
    while not (np.isfinite(part_at) and np.isfinite(open_at) and (np.isfinite(free_at) or not tells)):
        state = gripper.state()
        now = clock.now()
        stamp = _stamp(state, previous, now)
        late = now - previous > bounds.HAND_READ_GAP_MAX_S and stamp - previous > bounds.HAND_READ_GAP_MAX_S
        if not np.isfinite(part_at) and state.opening >= parting:
            if late:
                raise HostLate(now - previous)
            part_at = stamp
        if tells and not np.isfinite(free_at) and state.holding is False:
            if late:
                raise HostLate(now - previous)
            free_at = stamp
        if not np.isfinite(open_at) and state.opening >= bounds.HAND_OPEN_FRACTION:
            # read late, it opened between the two reads: the earlier, in its favour
            open_at = previous if late else stamp
        if now - t_r > timeout:
            what = "its jaws did not part" if not np.isfinite(part_at) else "it was not open"
            if np.isfinite(part_at) and tells and not np.isfinite(free_at):
                what = "it still held the ball"
            raise HandFault(f"{what} {timeout:.1f} s after the release (opening {state.opening:.2f})")
        previous = now
        clock.sleep(bounds.POLL_S)
    return part_at - t_r, (free_at - t_r) if tells else float("nan"), open_at - t_r


def _stats(values: list[float]) -> dict[str, float]:
    a = np.array([v for v in values if np.isfinite(v)])
    return {
        "median_s": float(np.median(a)) if a.size else float("nan"),
        "max_s": float(np.max(a)) if a.size else float("nan"),
        # all but the latest, which has a bound of its own: one late release does not make the jitter
        "jitter_s": float(np.std(np.sort(a)[:-1], ddof=1)) if a.size > 2 else float("nan"),
    }


def _open_first(gripper: Gripper, clock: Clock, times: HandTimes) -> None:
    """The hand open, its jaws at rest, before a cycle (a close then starts from where every close
    starts): told to open unless it was (a second open while one is on its way could fall due after
    the next close), then read every `JAWS_STILL_S` until its jaws rest open (open, and within
    `JAWS_STILL_OPENING` of the read before)."""
    timeout = times.timeout(times.open_s)
    told = clock.now()
    state = gripper.state()
    if state.command != "open":
        gripper.open()
    while True:
        clock.sleep(JAWS_STILL_S)
        now = gripper.state()
        if now.opening >= bounds.HAND_OPEN_FRACTION and abs(now.opening - state.opening) <= JAWS_STILL_OPENING:
            return
        if clock.now() - told > timeout:
            raise HandFault(f"not open {timeout:.1f} s after open() (opening {now.opening:.2f})")
        state = now


def probe_hand(gripper: Gripper, clock: Clock, times: HandTimes | None = None) -> CheckResult:
    """The hand's release over `HAND_CYCLES` close/release cycles (module docstring); `times`:
    the close and open times the settings state."""
    times = times or HandTimes()
    scheduled = isinstance(gripper, ScheduledOpen)
    cycles = Cycles()
    failures: list[str] = []
    host_late = False
    try:
        while len(cycles.part) < bounds.HAND_CYCLES:
            _open_first(gripper, clock, times)
            close_s, closed = _close(gripper, clock, times)
            try:
                part, free, opened = _release(gripper, clock, closed, scheduled, times)
            except HostLate as late:
                cycles.host_late.append(late.gap_s)
                if len(cycles.host_late) > bounds.HAND_HOST_LATE_CYCLES:
                    host_late = True
                    break
                continue  # the same cycle again
            cycles.close.append(close_s)
            cycles.part.append(part)
            cycles.free.append(free)
            cycles.open.append(opened)
    except HandFault as fault:
        failures.append(f"cycle {len(cycles.part) + 1}: {fault}")
    figures = _figures(cycles, scheduled, times)
    if host_late:
        return CheckResult(
            "hand",
            "not run",
            f"the host was late: it read the hand more than {1e3 * bounds.HAND_READ_GAP_MAX_S:.0f} ms after its read "
            f"before in {len(cycles.host_late)} cycles (by up to {1e3 * max(cycles.host_late):.0f} ms), so it could "
            f"not time the release (timed {len(cycles.part)} of {bounds.HAND_CYCLES}); not a fault of the hand: run "
            "the check on a quieter host",
            figures,
        )
    limits: dict[str, Any] = {}
    if not failures:
        failures += _judge(figures, limits, times)
    tells = figures["tells_holding"]
    summary = (
        f"the jaws part {_ms(figures['part_median_s'])} after the {'scheduled ' if scheduled else ''}release "
        f"(median of {len(cycles.part)}, jitter {_ms(figures['part_jitter_s'])}, at most {_ms(figures['part_max_s'])})"
        + (
            f", the ball free after {_ms(figures['free_median_s'])} (jitter {_ms(figures['free_jitter_s'])})"
            if tells
            else "; the hand did not say it held (no ball, or it cannot tell): judged on its jaws"
        )
        + f"; closed in {_ms(figures['close_median_s'])}, open in {_ms(figures['open_median_s'])}"
    )
    lead = figures["part_median_s"] + 2.0 * figures["part_jitter_s"]  # the latency and twice the jitter
    if np.isfinite(lead) and lead > 0:
        figures["suggested_open_lead_s"] = float(lead)
        summary += f"; the settings' hand_open_lead_s {_ms(lead)} lets the ball go before the follow-through brakes"
    warnings = [] if scheduled else [HOST_TIMED_WARNING]
    return judged("hand", figures, limits, failures, summary, warnings)


def _ms(seconds: float) -> str:
    return f"{1e3 * seconds:.1f} ms"


def _figures(cycles: Cycles, scheduled: bool, times: HandTimes) -> dict[str, Any]:
    tells = bool(cycles.free) and all(np.isfinite(cycles.free))
    figures: dict[str, Any] = {
        "schedules_open": scheduled,
        "release": "open_at" if scheduled else "open",
        "cycles": len(cycles.part),
        "host_late_cycles": len(cycles.host_late),
        "host_late_gap_max_s": max(cycles.host_late) if cycles.host_late else 0.0,
        "tells_holding": tells,
        "stated_close_s": times.close_s,
        "stated_open_s": times.open_s,
    }
    for name, values in (("close", cycles.close), ("part", cycles.part), ("free", cycles.free), ("open", cycles.open)):
        if name == "free" and not tells:
            continue
        figures[f"{name}_times_s"] = list(values)
        figures.update({f"{name}_{k}": v for k, v in _stats(values).items()})
    return figures


def _judge(figures: dict[str, Any], limits: dict[str, Any], times: HandTimes) -> list[str]:
    """The failures of the measured figures against the bounds (filled into `limits`)."""
    failures: list[str] = []
    what = {"part": "the jaws start to part", "free": "the ball is free"}
    for name in ("part", "free") if figures["tells_holding"] else ("part",):
        median, latest, jitter = (figures[f"{name}_{k}"] for k in ("median_s", "max_s", "jitter_s"))
        limits[f"{name}_median_s"] = {"max": bounds.HAND_RELEASE_MAX_S}
        limits[f"{name}_max_s"] = {"max": bounds.HAND_RELEASE_WORST_MAX_S}
        limits[f"{name}_jitter_s"] = {"max": bounds.HAND_JITTER_MAX_S}
        if median > bounds.HAND_RELEASE_MAX_S:
            failures.append(
                f"{what[name]} {_ms(median)} after the release (median; > {_ms(bounds.HAND_RELEASE_MAX_S)}): "
                "the ball leaves late, in the follow-through's brake"
            )
        elif latest > bounds.HAND_RELEASE_WORST_MAX_S:
            failures.append(
                f"{what[name]} once {_ms(latest)} after the release (> {_ms(bounds.HAND_RELEASE_WORST_MAX_S)})"
            )
        if jitter > bounds.HAND_JITTER_MAX_S:
            failures.append(f"{what[name]} with a jitter of {_ms(jitter)} (> {_ms(bounds.HAND_JITTER_MAX_S)})")
    for name, stated, setting in (("close", times.close_s, "hand_close_s"), ("open", times.open_s, "hand_open_s")):
        if stated > 0:
            limits[f"{name}_max_s"] = {"max": stated}
            if figures[f"{name}_max_s"] > stated:
                failures.append(
                    f"{'closed' if name == 'close' else 'open'} in up to {_ms(figures[f'{name}_max_s'])}, slower than "
                    f"the settings' {setting} {_ms(stated)}"
                )
    return failures
