"""The hand's probe of `wiithrow check-driver`: `probe_hand`, through the `Gripper` interface only,
read every `bounds.POLL_S` on the clock the driver was given.

`HAND_CYCLES` times close, wait, open: the time from `open()` (the clock) until
the hand reports open (opening >= `HAND_OPEN_FRACTION`; the timestamp of that state, so that the
reads' own timing does not add to the jitter, or the clock when it was read if its timestamp is
not between the two): median (latency), jitter (the standard deviation of all opens but the
latest, so that one open seen late by a busy host does not make it), the latest; a hand that
schedules opens (`ScheduledOpen`) as many times again with `open_at(now + HAND_SCHEDULE_LEAD_S)`,
timed from the time it was given: its median and jitter (all of them: its own clock times it).
An open is timed only when the host read the hand within `HAND_READ_GAP_MAX_S` of its read
before (which saw it closed), or the state's timestamp is within that of it: a host that read it
later, and got a state stamped as late, cannot say when it opened, and that cycle is done again
(`host_late_cycles`): a loaded host's lateness is not the hand's. (A hand whose state is
sampled coarsely is read on time: its own quantisation counts.)

A hand without the scheduled open is host-timed: the host calls `open()` when the release time
comes, so a host stalled then (a camera read, a flood of network frames) opens it late. The check
passes such a hand on its timing but warns (`HOST_TIMED_WARNING`; `schedules_open` in the
figures): a throw refuses to release later than its bound (`RELEASE_LATE_BOUND_S` in
`wiithrow.app.throws.execution`), ending before the release with the ball kept, and a driver with
`open_at` removes the risk.
"""

from __future__ import annotations

import numpy as np

from wiithrow.app.drivercheck import bounds
from wiithrow.app.drivercheck.report import CheckResult, judged
from wiithrow.clock import Clock
from wiithrow.robot.gripper import Gripper, ScheduledOpen, schedules_open

#: The hand check's warning for a hand without `open_at` (module docstring).
HOST_TIMED_WARNING = (
    "host-timed hand: it has no scheduled open (open_at), so the host times its release and a host "
    "stalled at the release opens it late; a throw then refuses to release later than its bound "
    "(RELEASE_LATE_BOUND_S, wiithrow.app.throws.execution) and ends with the ball kept; a driver with "
    "open_at (wiithrow.robot.gripper.ScheduledOpen) opens on the hand's own clock and removes the risk"
)


def _wait(gripper: Gripper, clock: Clock, seconds: float) -> float:
    """Read the hand every POLL_S for `seconds`; its opening at the end."""
    end = clock.now() + seconds
    opening = float(gripper.state().opening)
    while clock.now() < end:
        clock.sleep(min(bounds.POLL_S, end - clock.now()))
        opening = float(gripper.state().opening)
    return opening


def probe_hand(gripper: Gripper, clock: Clock) -> CheckResult:
    """The hand's open latency and jitter over `HAND_CYCLES` close/open cycles (module docstring)."""
    latencies: list[float] = []
    failures: list[str] = []
    scheduled: list[float] = []  # the same from the time given to `open_at`, if the hand has it
    modes = ["open"] * bounds.HAND_CYCLES + (["open_at"] * bounds.HAND_CYCLES if schedules_open(gripper) else [])
    late = {"open": 0, "open_at": 0}  # cycles done again: the host read the hand too late to time them
    cycle = 0
    while cycle < len(modes):
        mode = modes[cycle]
        gripper.close()
        closed = _wait(gripper, clock, bounds.HAND_CLOSE_WAIT_S)
        if closed >= bounds.HAND_OPEN_FRACTION:
            failures.append(
                f"cycle {cycle + 1}: still reports open ({closed:.2f}) {bounds.HAND_CLOSE_WAIT_S} s after close()"
            )
            break
        t_open = clock.now()
        if isinstance(gripper, ScheduledOpen) and mode == "open_at":
            t_open += bounds.HAND_SCHEDULE_LEAD_S
            gripper.open_at(t_open)
        else:
            gripper.open()
        seen, host_late = float("nan"), False
        previous = clock.now()  # when the host last read the hand closed
        while clock.now() - t_open <= bounds.HAND_TIMEOUT_S:
            state = gripper.state()
            now = clock.now()
            if state.opening >= bounds.HAND_OPEN_FRACTION:
                stamp = state.t if t_open <= state.t <= now else now
                seen = stamp - t_open
                # read late, and stamped late: the open happened somewhere in the host's gap
                host_late = (
                    now - previous > bounds.HAND_READ_GAP_MAX_S and stamp - previous > bounds.HAND_READ_GAP_MAX_S
                )
                break
            previous = now
            clock.sleep(bounds.POLL_S)
        if not np.isfinite(seen):
            failures.append(f"cycle {cycle + 1}: not open {bounds.HAND_TIMEOUT_S} s after {mode}()")
            break
        _wait(gripper, clock, 0.05)
        if host_late:
            late[mode] += 1
            if late[mode] > bounds.HAND_CYCLES:
                failures.append(
                    f"the host read the hand too late to time its opens: {late[mode]} {mode}() cycles read "
                    f"more than {1e3 * bounds.HAND_READ_GAP_MAX_S:.0f} ms after the read before, the state stamped as late "
                    "(a busy host, or a state() that takes that long: run the check on a quiet host)"
                )
                break
            continue  # the same cycle again
        (latencies if mode == "open" else scheduled).append(seen)
        cycle += 1
    lat = np.array(latencies)
    figures = {
        "schedules_open": schedules_open(gripper),
        "cycles": len(latencies),
        "host_late_cycles": late["open"] + late["open_at"],
        "open_latencies_s": lat.tolist(),
        "latency_median_s": float(np.median(lat)) if lat.size else float("nan"),
        # the standard deviation of all opens but the latest (which has a bound of its own): one
        # open seen late by a busy host does not make the jitter
        "jitter_s": float(np.std(np.sort(lat)[:-1], ddof=1)) if lat.size > 2 else float("nan"),
        "latency_std_s": float(np.std(lat, ddof=1)) if lat.size > 1 else float("nan"),
        "latency_max_s": float(np.max(lat)) if lat.size else float("nan"),
    }
    if scheduled:  # on the hand's own clock: every open counts for the jitter
        figures["scheduled_open_latencies_s"] = scheduled
        figures["scheduled_latency_median_s"] = float(np.median(scheduled))
        figures["scheduled_jitter_s"] = float(np.std(scheduled, ddof=1)) if len(scheduled) > 1 else float("nan")
    limits = {
        "latency_median_s": {"max": bounds.HAND_LATENCY_MAX_S},
        "jitter_s": {"max": bounds.HAND_JITTER_MAX_S},
        "latency_max_s": {"max": bounds.HAND_LATENCY_WORST_MAX_S},
    }
    if scheduled:
        limits["scheduled_latency_median_s"] = {"max": bounds.HAND_LATENCY_MAX_S}
        limits["scheduled_jitter_s"] = {"max": bounds.HAND_JITTER_MAX_S}
        if not failures and figures["scheduled_latency_median_s"] > bounds.HAND_LATENCY_MAX_S:
            failures.append(f"scheduled opens late: median {1e3 * figures['scheduled_latency_median_s']:.1f} ms")
        if not failures and figures["scheduled_jitter_s"] > bounds.HAND_JITTER_MAX_S:
            failures.append(f"scheduled open jitter {1e3 * figures['scheduled_jitter_s']:.1f} ms")
    if not failures:
        if figures["latency_median_s"] > bounds.HAND_LATENCY_MAX_S:
            failures.append(
                f"opens late: median {1e3 * figures['latency_median_s']:.1f} ms > {1e3 * bounds.HAND_LATENCY_MAX_S:.0f} ms"
            )
        if figures["jitter_s"] > bounds.HAND_JITTER_MAX_S:
            failures.append(f"jitter {1e3 * figures['jitter_s']:.1f} ms > {1e3 * bounds.HAND_JITTER_MAX_S:.0f} ms")
        if figures["latency_max_s"] > bounds.HAND_LATENCY_WORST_MAX_S:
            failures.append(
                f"opened once after {1e3 * figures['latency_max_s']:.0f} ms > {1e3 * bounds.HAND_LATENCY_WORST_MAX_S:.0f} ms"
            )
    summary = (
        f"open after {1e3 * figures['latency_median_s']:.1f} ms (median of {len(latencies)}), jitter "
        f"{1e3 * figures['jitter_s']:.1f} ms, at most {1e3 * figures['latency_max_s']:.1f} ms"
    )
    if scheduled:
        summary += (
            f"; scheduled: {1e3 * figures['scheduled_latency_median_s']:.1f} ms after its time, "
            f"jitter {1e3 * figures['scheduled_jitter_s']:.1f} ms"
        )
    warnings = [] if schedules_open(gripper) else [HOST_TIMED_WARNING]
    return judged("hand", figures, limits, failures, summary, warnings)
