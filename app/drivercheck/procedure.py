"""The order of `wiithrow check-driver`'s probes, what gates what, and the safe end of each.

1. `state` (the arm at rest), 2. `slow motion` (every joint out by 0.1 rad and back, slowly),
3. `state measured` (the state itself, on what 1 and 2 read: not an echo of the command,
`plausibility`), 4. `limits refused`, 5. `stop`, 6. `seen moving` (the calibrated rig watches
the hand's LED while the arm moves slowly to where the rig sees it and back, `rig_probe`; not
run without a calibrated rig), 7. `scaled throw`, then the arm goes back (slowly) to where it
started, 8. `hand` (when the settings name one).

The scaled throw runs only on a driver none of the checks before it failed: an arm whose state is
stale or a copy of its command, that does not follow a slow motion, takes a command beyond its
limits, ignores Stop or is not where the rig sees it is not given a throw, however gentle (the
report says so: "not run", which is not a pass). After a
probe that failed by an exception the arm is stopped; a later motion is commanded only once the
arm is idle again. Any exception that escapes (a bug, Ctrl-C) stops the arm and opens the hand
on its way out: the check never holds anything.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from wiithrow.app.drivercheck import bounds, motions
from wiithrow.app.drivercheck.hand_probe import probe_hand
from wiithrow.app.drivercheck.plausibility import probe_measured
from wiithrow.app.drivercheck.probes import (
    Recording,
    probe_following,
    probe_limits,
    probe_scaled_throw,
    probe_state,
    probe_stop,
)
from wiithrow.app.drivercheck.report import CheckResult, not_run
from wiithrow.app.drivercheck.rig_probe import RigWatch, probe_seen_moving
from wiithrow.app.errors import expected_errors
from wiithrow.clock import Clock
from wiithrow.robot import Arm, ArmModel
from wiithrow.robot.gripper import Gripper
from wiithrow.throwing import ThrowLibrary

#: The checks, in the order they run.
CHECK_NAMES = (
    "state",
    "slow motion",
    "state measured",
    "limits refused",
    "stop",
    "seen moving",
    "scaled throw",
    "hand",
)
#: How long (s) the arm may take to be idle before a probe.
IDLE_TIMEOUT_S = 10.0


def run_checks(
    arm: Arm,
    model: ArmModel,
    clock: Clock,
    *,
    gripper: Gripper | None,
    library: ThrowLibrary | None,
    say: Callable[[str], None] = lambda message: None,
    watch: RigWatch | None = None,
) -> tuple[CheckResult, ...]:
    """Every check on `arm` (and `gripper`; `watch`: the calibrated rig that sees the hand's LED,
    None without one), in order (module docstring)."""
    results: dict[str, CheckResult] = {}
    try:
        _arm_checks(arm, model, clock, library, results, say, watch)
        if gripper is None:
            results["hand"] = not_run("hand", "no gripper_driver in the settings: a throw needs a hand")
        else:
            say("hand: close and open")
            results["hand"] = _guarded("hand", lambda: probe_hand(gripper, clock), lambda: gripper.open())
    except BaseException:
        arm.stop()
        if gripper is not None:
            gripper.open()
        raise
    return tuple(results[name] for name in CHECK_NAMES)


def _guarded(name: str, probe: Callable[[], CheckResult], safe: Callable[[], None]) -> CheckResult:
    """`probe()`, or a failed check saying what it raised (after `safe()`) for an expected error."""
    try:
        return probe()
    except expected_errors() as exc:
        safe()
        return CheckResult(name, "fail", f"raised {type(exc).__name__}: {exc}")


def _arm_checks(
    arm: Arm,
    model: ArmModel,
    clock: Clock,
    library: ThrowLibrary | None,
    results: dict[str, CheckResult],
    say: Callable[[str], None],
    watch: RigWatch | None,
) -> None:
    names = CHECK_NAMES[:-1]
    rest: list[Recording] = []
    moving: list[Recording] = []

    def idle() -> bool:
        return arm.wait_until_idle(IDLE_TIMEOUT_S)

    def skip_rest(why: str) -> None:
        for name in names:
            results.setdefault(name, not_run(name, why))

    if not idle():
        skip_rest(f"the arm did not come to rest within {IDLE_TIMEOUT_S:.0f} s before the check")
        return
    q_start = np.array(arm.state().q, dtype=float)
    say("state: the arm at rest")
    results["state"] = _guarded("state", lambda: probe_state(arm, clock, rest), arm.stop)

    say("slow motion: every joint out by 0.1 rad and back")
    results["slow motion"] = _guarded(
        "slow motion",
        lambda: probe_following(
            "slow motion",
            arm,
            model,
            clock,
            motions.slow_out_and_back(model, np.array(arm.state().q, dtype=float)),
            rms_max=bounds.SLOW_RMS_MAX_RAD,
            max_max=bounds.SLOW_MAX_MAX_RAD,
            keep=moving,
        ),
        arm.stop,
    )
    results["state measured"] = probe_measured(rest[0] if rest else None, moving[0] if moving else None)
    if not idle():
        skip_rest("the arm did not come to rest after the slow motion")
        return
    say("limits: commands beyond each joint's limits")
    results["limits refused"] = _guarded("limits refused", lambda: probe_limits(arm, model, clock), arm.stop)
    if not idle():
        skip_rest("the arm did not come to rest after the commands beyond its limits")
        return
    say("stop: Stop during a move")
    results["stop"] = _guarded(
        "stop",
        lambda: probe_stop(arm, model, clock, motions.stop_move(model, np.array(arm.state().q, dtype=float))),
        arm.stop,
    )
    if not idle():
        skip_rest("the arm did not come to rest after Stop")
        return
    if watch is not None:
        say("seen moving: the rig watches the hand's LED while the arm moves slowly where it sees it")
    results["seen moving"] = _guarded("seen moving", lambda: probe_seen_moving(arm, model, clock, watch), arm.stop)
    if not idle():
        skip_rest("the arm did not come to rest after the rig watched it")
        return
    failed = [name for name in names[:6] if results[name].status == "fail"]
    if failed:
        results["scaled throw"] = not_run(
            "scaled throw",
            f"a throw is only tried on a driver that passed the checks before it ({', '.join(failed)} did not)",
        )
    elif library is None:
        results["scaled throw"] = not_run(
            "scaled throw", f"no throw library for arm {model.name!r} to plan the throw from"
        )
    else:
        say(f"scaled throw: a planned throw slowed down {bounds.THROW_TIME_SCALE:g} times")
        results["scaled throw"] = _guarded(
            "scaled throw", lambda: probe_scaled_throw(arm, model, clock, library), arm.stop
        )
    if idle():
        here = np.array(arm.state().q, dtype=float)
        if np.max(np.abs(here - q_start)) > 1e-3:
            say("back to where the check started")
            try:
                arm.command_trajectory(motions.slow_move(model, here, q_start))
            except expected_errors() as exc:
                arm.stop()
                say(f"the arm stays where it is: the move back was refused ({exc})")
            idle()
