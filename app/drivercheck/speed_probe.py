"""The check "throwing speed" of `wiithrow check-driver`: does the arm reach the speeds its spec
claims, where a throw needs them?

The slow motions and the scaled throw (half the speed) pass an arm whose drive cannot go faster
than a third of its spec's velocity limits; the first real throw does not. Here the arm runs
`motions.throwing_speed`: its throw shape planned from its model with every throwing joint
released at `bounds.THROW_SPEED_FRACTION` of its velocity limit (the fastest a trained throw asks
of it), validated, from its wind-up pose (reached slowly first), the hand empty: nothing is
thrown. Each throwing joint's speed is measured from its positions, not from the state's
velocities (which a driver may compute from its command): the largest difference of q over
`bounds.SPEED_SPAN_S` of the states' timestamps,

    v_j = max_k |q_j(t_k') - q_j(t_k)| / (t_k' - t_k),   t_k' the first state >= t_k + span,

and judged against the planned peak: every throwing joint reaches at least
`SPEED_REACHED_MIN` of it, else the check fails naming the joint and the figures ("joint E1
reached 0.67 rad/s of a planned 1.71 (39 %)").

A host that did not read the arm while it was fast (a gap of more than `SPEED_GAP_MAX_S` between
new states while the command ran above half its peak) cannot say how fast it went: a joint short
of the bound then is the host's (`figures["host_late"]`), and the check is tried again.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray

from wiithrow.app.drivercheck import bounds, motions
from wiithrow.app.drivercheck.host import host_lateness, host_mark
from wiithrow.app.drivercheck.probes import record, timed_command
from wiithrow.app.drivercheck.report import CheckResult, judged, not_run
from wiithrow.app.errors import AppError
from wiithrow.clock import Clock
from wiithrow.robot import Arm, ArmModel
from wiithrow.throwing import Ball, ThrowingError

#: Every throwing joint reaches at least this fraction of its planned peak speed. The arms the
#: project drives reach 98-100 % (the MuJoCo PA-10's velocity-mode servo: 99 %); a joint 10 %
#: slow at the release throws about 20 % short (the range goes with the square of the speed), far
#: beyond what the planner's model and the learning are built to absorb.
SPEED_REACHED_MIN = 0.9
#: The longest gap (s) between new states, while the command is fast, that still measures the
#: peak: within 10 ms a joint at the release (no acceleration) changes speed by jerk x 0.01^2 / 2,
#: under 1 % of it on the shipped arms.
SPEED_GAP_MAX_S = 0.010


def peak_speeds(
    t: NDArray[np.float64], q: NDArray[np.float64], span: float = bounds.SPEED_SPAN_S
) -> NDArray[np.float64]:
    """The largest speed (rad/s) of each column of q (N, n) at increasing times t (N,), from the
    differences of its positions over `span` (module docstring); NaN with no two samples `span`
    apart."""
    later = np.searchsorted(t, t + span - 1e-9)
    ok = later < t.size
    i, k = np.flatnonzero(ok), later[ok]
    if i.size == 0:
        return np.full(q.shape[1], np.nan)
    return np.max(np.abs(q[k] - q[i]) / (t[k] - t[i])[:, None], axis=0)


def probe_throwing_speed(arm: Arm, model: ArmModel, clock: Clock, ball: Ball | None = None) -> CheckResult:
    """The throwing-speed motion, judged by the speed reached (module docstring). Not run when the
    arm's model plans no throw (no throwing section in its spec)."""
    name = "throwing speed"
    q0 = np.array(arm.state().q, dtype=float)
    try:
        motion = motions.throwing_speed(model, q0, ball)
    except (ThrowingError, AppError) as exc:
        return not_run(name, f"no throwing-speed motion planned from the model of arm {model.name!r}: {exc}")
    timed_command(arm, clock, motion.windup)
    record(arm, clock, motion.windup.duration)
    if not arm.wait_until_idle(5.0):
        raise AppError("the arm did not come to rest at the wind-up pose of the throwing-speed motion")
    mark = host_mark(clock)
    t0, call_s = timed_command(arm, clock, motion.throw)
    samples = record(arm, clock, motion.throw.duration + bounds.SETTLE_S)
    lateness = host_lateness(clock, mark)
    joints = list(motion.joints)
    new = samples.new()
    reached = peak_speeds(new.t, new.q[:, joints])
    throw = motion.throw
    grid = np.arange(0.0, throw.duration, 0.001)
    planned = peak_speeds(grid, throw.sample(grid)[0][:, joints])  # the command's, measured alike
    ratio = reached / planned
    joint_names = [model.joint_names[j] for j in motion.joints]
    # the largest gap between new states while the command ran above half its peak
    t_rel = new.t - t0
    _, dq_cmd, _ = motion.throw.sample(np.clip(t_rel, 0.0, motion.throw.duration))
    fast = np.max(np.abs(dq_cmd[:, joints]) / motion.planned_speed, axis=1) >= 0.5
    fast &= (t_rel >= 0.0) & (t_rel <= motion.throw.duration)
    gaps = np.diff(new.t)
    fast_gap = float(np.max(gaps[fast[1:] | fast[:-1]])) if fast.sum() > 1 else float("inf")
    figures: dict[str, Any] = {
        "joints": joint_names,
        "planned_speed_rad_s": planned.tolist(),
        "release_speed_rad_s": motion.planned_speed.tolist(),
        "planned_of_limit": (planned / model.velocity_limit[joints]).tolist(),
        "reached_speed_rad_s": reached.tolist(),
        "reached_of_planned": ratio.tolist(),
        "worst_reached_of_planned": float(np.nanmin(ratio)) if np.isfinite(ratio).any() else float("nan"),
        "states": int(new.t.size),
        "fast_gap_max_s": fast_gap,
        "command_call_s": call_s,
        "release_time_s": motion.release_time,
    }
    limits = {"worst_reached_of_planned": {"min": SPEED_REACHED_MIN}}
    failures = [
        f"joint {joint_names[i]} reached {reached[i]:.2f} rad/s of a planned {planned[i]:.2f} ({100 * ratio[i]:.0f} %)"
        for i in range(len(joint_names))
        if not ratio[i] >= SPEED_REACHED_MIN
    ]
    if failures:
        failures[-1] += (
            f": below {100 * SPEED_REACHED_MIN:.0f} %, it cannot reach the speeds its spec claims "
            "(its velocity limits), the speeds a throw is planned with"
        )
        if fast_gap > SPEED_GAP_MAX_S:
            figures["host_late"] = f"it read no state for {1e3 * fast_gap:.0f} ms while the arm was fast" + (
                f" ({lateness.line()})" if lateness is not None else ""
            )
    summary = ", ".join(
        f"{joint_names[i]} {reached[i]:.2f} of {planned[i]:.2f} rad/s ({100 * ratio[i]:.0f} %)"
        for i in range(len(joint_names))
    )
    summary = f"reached {summary} (planned at up to {100 * bounds.THROW_SPEED_FRACTION:.1f} % of the velocity limits)"
    return judged(name, figures, limits, failures, summary)
