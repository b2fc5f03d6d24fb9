"""The order of `wiithrow check-driver`'s probes, what gates what, and the safe end of each.

1. `state` (the arm at rest), 2. `slow motion` (every joint out by 0.1 rad and back, slowly),
3. `state measured` (the state itself, on what 1 and 2 read: not an echo of the command,
`plausibility`), 4. `limits refused`, 5. `stop`, 6. `seen moving` (the calibrated rig watches
the hand's LED while the arm moves slowly to where the rig sees it and back, `rig_probe`; not
run without a calibrated rig), 7. `scaled throw` (a throw planned from the arm's model, slowed
down), 8. `throwing speed` (the throw shape at the speed of the fastest throws, `speed_probe`),
then the arm goes back (slowly) to where it started, 9. `hand` (when the settings name one).

The two fast motions run only on a driver none of the checks 1-6 failed: an arm whose state is
stale or a copy of its command, that does not follow a slow motion, takes a command beyond its
limits, ignores Stop or is not where the rig sees it is not given a throw, however gentle (the
report says so: "not run", which is not a pass); and only with the hand empty (a hand that says it
holds something is not swung: the check throws nothing). Both run whatever the other found: an
arm that follows half its speed well may not reach its full speed, and one that cannot reach its
speed fails the slowed throw too, where only the speed says why.

A following check that failed (slow motion, scaled throw) ends its reason with the terms its
controller is missing, measured (`lag_cause.diagnose`: a sag under gravity at rest, a lag in
proportion to speed, a delay). The checks run on a `host.HostWatch` of the driver's clock: a
failure the host's lateness explains is tried again and, if it stays the host's, reported as not
run with how late the host was (`host.retried`), never as the driver's.

After a probe that failed by an exception the arm is stopped; a later motion is commanded only
once the arm is idle again. Any exception that escapes (a bug, Ctrl-C) stops the arm and opens the
hand on its way out: the check never holds anything.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, replace

import numpy as np
from numpy.typing import NDArray

from wiithrow.app.drivercheck import bounds, motions
from wiithrow.app.drivercheck.hand_probe import HandTimes, probe_hand
from wiithrow.app.drivercheck.host import HostWatch, retried
from wiithrow.app.drivercheck.lag_cause import diagnose, wait_still
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
from wiithrow.app.drivercheck.speed_probe import probe_throwing_speed
from wiithrow.app.errors import expected_errors
from wiithrow.clock import Clock
from wiithrow.robot import Arm, ArmModel
from wiithrow.robot.gripper import Gripper
from wiithrow.throwing import Ball

#: The checks, in the order they run.
CHECK_NAMES = (
    "state",
    "slow motion",
    "state measured",
    "limits refused",
    "stop",
    "seen moving",
    "scaled throw",
    "throwing speed",
    "hand",
)
#: The checks before the fast motions, any of which failing keeps the arm from them.
BEFORE_FAST = CHECK_NAMES[:6]
#: How long (s) the arm may take to be idle before a probe.
IDLE_TIMEOUT_S = 10.0


def run_checks(
    arm: Arm,
    model: ArmModel,
    clock: Clock,
    *,
    gripper: Gripper | None,
    ball: Ball | None = None,
    hand_times: HandTimes | None = None,
    say: Callable[[str], None] = lambda message: None,
    watch: RigWatch | None = None,
) -> tuple[CheckResult, ...]:
    """Every check on `arm` (and `gripper`, with the close and open times the settings state;
    `ball`: the settings' ball, which the throws are planned for; `watch`: the calibrated rig that
    sees the hand's LED, None without one), in order (module docstring)."""
    results: dict[str, CheckResult] = {}
    host = HostWatch(clock)
    try:
        _arm_checks(_Run(arm, model, host, ball, gripper, say), results, watch)
        if gripper is None:
            results["hand"] = not_run("hand", "no gripper_driver in the settings: a throw needs a hand")
        else:
            say("hand: close and release")
            results["hand"] = _guarded("hand", lambda: probe_hand(gripper, host, hand_times), gripper.open)
            arm.wait_until_idle(IDLE_TIMEOUT_S)  # the ball's drops jostle the arm: it ends at rest
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


@dataclass(frozen=True)
class _Run:
    """What every arm probe of one check run works with."""

    arm: Arm
    model: ArmModel
    host: HostWatch
    ball: Ball | None
    gripper: Gripper | None
    say: Callable[[str], None]

    def idle(self) -> bool:
        return self.arm.wait_until_idle(IDLE_TIMEOUT_S)

    def q(self) -> NDArray[np.float64]:
        return np.array(self.arm.state().q, dtype=float)

    def check(self, name: str, probe: Callable[[], CheckResult]) -> CheckResult:
        """`probe` guarded (an exception stops the arm) and tried again, from rest, while the
        host's lateness explains its failure."""

        def once() -> CheckResult:
            self.idle()
            return _guarded(name, probe, self.arm.stop)

        return retried(name, once, self.host, self.say)

    def explained(self, result: CheckResult, moving: list[Recording]) -> CheckResult:
        """A following check that failed, its reason ending with the missing terms (`diagnose`)."""
        if result.status != "fail" or not moving or moving[-1].traj is None or not wait_still(self.arm, self.host):
            return result
        recording = moving[-1]
        assert recording.traj is not None
        self.say(f"{result.name}: why the arm is off its command (at rest under two gravity loads)")
        try:
            found = diagnose(self.arm, self.model, self.host, recording, recording.traj.positions[-1])
        except expected_errors() as exc:
            self.arm.stop()
            return replace(result, figures={**result.figures, "diagnosis_error": str(exc)})
        if not found.lines:
            return replace(result, figures={**result.figures, "diagnosis": found.figures})
        return replace(
            result, reason=f"{result.reason}; {found.reason()}", figures={**result.figures, "diagnosis": found.figures}
        )


def _arm_checks(run: _Run, results: dict[str, CheckResult], watch: RigWatch | None) -> None:
    arm, model, host, say = run.arm, run.model, run.host, run.say
    names = CHECK_NAMES[:-1]
    rest: list[Recording] = []
    moving: list[Recording] = []

    def skip_rest(why: str) -> None:
        for name in names:
            results.setdefault(name, not_run(name, why))

    if not run.idle():
        skip_rest(f"the arm did not come to rest within {IDLE_TIMEOUT_S:.0f} s before the check")
        return
    q_start = run.q()
    say("state: the arm at rest")
    results["state"] = run.check("state", lambda: probe_state(arm, host, rest))

    say("slow motion: every joint out by 0.1 rad and back")
    slow = run.check(
        "slow motion",
        lambda: probe_following(
            "slow motion",
            arm,
            model,
            host,
            motions.slow_out_and_back(model, run.q()),
            rms_max=bounds.SLOW_RMS_MAX_RAD,
            max_max=bounds.SLOW_MAX_MAX_RAD,
            keep=moving,
        ),
    )
    results["slow motion"] = run.explained(slow, moving)
    results["state measured"] = probe_measured(rest[-1] if rest else None, moving[0] if moving else None)
    if not run.idle():
        skip_rest("the arm did not come to rest after the slow motion")
        return
    say("limits: commands beyond each joint's limits")
    results["limits refused"] = _guarded("limits refused", lambda: probe_limits(arm, model, host), arm.stop)
    if not run.idle():
        skip_rest("the arm did not come to rest after the commands beyond its limits")
        return
    say("stop: Stop during a move")
    results["stop"] = run.check("stop", lambda: probe_stop(arm, model, host, motions.stop_move(model, run.q())))
    if not run.idle():
        skip_rest("the arm did not come to rest after Stop")
        return
    if watch is not None:
        say("seen moving: the rig watches the hand's LED while the arm moves slowly where it sees it")
    results["seen moving"] = run.check("seen moving", lambda: probe_seen_moving(arm, model, host, watch))
    if not run.idle():
        skip_rest("the arm did not come to rest after the rig watched it")
        return
    _fast_checks(run, results)
    if run.idle():
        here = run.q()
        if np.max(np.abs(here - q_start)) > 1e-3:
            say("back to where the check started")
            try:
                arm.command_trajectory(motions.slow_move(model, here, q_start))
            except expected_errors() as exc:
                arm.stop()
                say(f"the arm stays where it is: the move back was refused ({exc})")
            run.idle()


def _fast_checks(run: _Run, results: dict[str, CheckResult]) -> None:
    """The scaled throw and the throwing speed, gated (module docstring)."""
    failed = [name for name in BEFORE_FAST if results[name].status == "fail"]
    held = run.gripper is not None and run.gripper.state().holding is True
    for name in ("scaled throw", "throwing speed"):
        if failed:
            results[name] = not_run(
                name,
                f"a throw is only tried on a driver that passed the checks before it ({', '.join(failed)} did not)",
            )
        elif held:
            results[name] = not_run(
                name, "the hand holds something: the check moves at throwing speed with an empty hand (take it out)"
            )
    if failed or held:
        return
    arm, model, host, ball = run.arm, run.model, run.host, run.ball
    moving: list[Recording] = []
    run.say(f"scaled throw: a throw planned from the arm's model, slowed down {bounds.THROW_TIME_SCALE:g} times")
    throw = run.check("scaled throw", lambda: probe_scaled_throw(arm, model, host, ball, keep=moving))
    results["scaled throw"] = run.explained(throw, moving)
    if not run.idle():
        results["throwing speed"] = not_run("throwing speed", "the arm did not come to rest after the scaled throw")
        return
    run.say(f"throwing speed: the throw's joints at {100 * bounds.THROW_SPEED_FRACTION:.1f} % of their velocity limits")
    results["throwing speed"] = run.check("throwing speed", lambda: probe_throwing_speed(arm, model, host, ball))
