"""The motions `wiithrow check-driver` commands, each validated before the arm sees it.

Nothing moves the arm here but `Arm.command_trajectory` with a trajectory that passed the
throwing validator (`wiithrow.throwing.validator.validate`: every sample's position, velocity,
acceleration and jerk against the arm's limits, its finite differences, the floor, rest at both
ends), sampled at 1 ms:

* `slow_out_and_back`: every joint out by `bounds.SLOW_STEP_RAD` (away from its nearer limit)
  and back, Ruckig moves at `bounds.SLOW_LIMIT_FRACTION` of the limits;
* `stop_move`: every joint out by `bounds.STOP_MOVE_RAD` at `bounds.STOP_LIMIT_FRACTION` of the
  limits: the move that Stop interrupts;
* `scaled_throw`: the throw training's first throws are, planned from the arm's model with no
  library: the simulated operator's solution (`throwing.operator.solve_throw`) for the middle of
  the arm's training area (its spec's; nearer, halfway at a time, where the model cannot reach
  it), planned (`plan_throw`) from the arm's pose (its prelude to the wind-up pose included) and
  validated (`require_valid`), then time-scaled by `bounds.THROW_TIME_SCALE`:

      t' = s t,  q'(t') = q(t' / s),  dq' = dq / s,  ddq' = ddq / s^2   (jerk / s^3)

  the same path, gentler at every sample, and validated again as it is;
* `throwing_speed`: the arm's throw shape at the speed of its fastest throws, planned from its
  model: released at the operator's preferred release pose (its spec's, kept where the wind-up
  and the follow-through fit in the limits, as the operator keeps it) with every throwing joint
  at `bounds.THROW_SPEED_FRACTION` of its velocity limit in its throwing direction (less where
  its acceleration or jerk limit caps the acceleration phase), validated as a throw; the slow
  move to its wind-up pose comes first, on its own;
* `slow_move`: back to where the check started, at the slow fraction of the limits.

Nothing here throws a ball: the check runs its motions with the hand empty
(`wiithrow.app.drivercheck.procedure`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from wiithrow.app.drivercheck import bounds
from wiithrow.app.errors import AppError
from wiithrow.robot import ArmModel, JointTrajectory, plan_move
from wiithrow.throwing import Ball, ThrowingError, ThrowParameters, UnreachableTargetError, shape_for, training_area
from wiithrow.throwing.arm_throwing import directions, nominal_release
from wiithrow.throwing.limiting import plan_throw
from wiithrow.throwing.operator import solve_throw
from wiithrow.throwing.representation import ACCEL_PEAK_FACTOR, JERK_PEAK_FACTOR
from wiithrow.throwing.validator import ValidatedThrow, require_valid, validate

#: A joint's excursion keeps this far (rad) from its limit.
LIMIT_CLEARANCE_RAD = 0.02
#: The scaled throw's target moves halfway to the area's near edge at most this many times while
#: the model cannot reach it.
REACH_TRIES = 4
#: The room the simulated operator keeps for the follow-through ahead of the release pose (rad;
#: `operator.solve_throw`), and behind it for the wind-up beyond half its travel.
FOLLOW_THROUGH_ROOM_RAD = 0.6
WIND_UP_ROOM_RAD = 0.05


@dataclass(frozen=True)
class ScaledThrow:
    """A planner's throw slowed down: `trajectory` (validated), `release_time` (s, on its axis),
    `target` (x, z) in link1 (m) the unscaled throw was planned for, `scale`."""

    trajectory: JointTrajectory
    release_time: float
    target: tuple[float, float]
    scale: float


def validated(traj: JointTrajectory, model: ArmModel, what: str) -> JointTrajectory:
    """`traj` if the validator passes it, else AppError naming the violations (nothing moves)."""
    report = validate(traj, model)
    if not report.ok:
        raise AppError(f"the check's {what} was rejected by the validator: {report.summary()}")
    return traj


def excursion(model: ArmModel, q0: NDArray[np.float64], step: float) -> NDArray[np.float64]:
    """q0 with every joint moved by up to `step` (rad) towards its farther limit, keeping
    `LIMIT_CLEARANCE_RAD` from it."""
    up = model.upper - q0
    down = q0 - model.lower
    direction = np.where(up >= down, 1.0, -1.0)
    room = np.maximum(np.maximum(up, down) - LIMIT_CLEARANCE_RAD, 0.0)
    return q0 + direction * np.minimum(step, room)


def chain(first: JointTrajectory, second: JointTrajectory) -> JointTrajectory:
    """`second` after `first` (its first sample, equal to `first`'s last, dropped)."""
    t = np.concatenate([first.times, first.times[-1] + second.times[1:] - second.times[0]])
    return JointTrajectory(
        t,
        np.vstack([first.positions, second.positions[1:]]),
        np.vstack([first.velocities, second.velocities[1:]]),
        np.vstack([first.accelerations, second.accelerations[1:]]),
    )


def slow_move(model: ArmModel, q_from: NDArray[np.float64], q_to: NDArray[np.float64]) -> JointTrajectory:
    """A validated rest-to-rest move at the slow fraction of the limits."""
    f = bounds.SLOW_LIMIT_FRACTION
    q_from = np.clip(q_from, model.lower, model.upper)
    return validated(plan_move(q_from, q_to, model.limits.scaled(f, f, f)), model, "slow move")


def slow_out_and_back(model: ArmModel, q0: NDArray[np.float64]) -> JointTrajectory:
    """Every joint out by `SLOW_STEP_RAD` and back to q0, slowly (module docstring)."""
    f = bounds.SLOW_LIMIT_FRACTION
    limits = model.limits.scaled(f, f, f)
    q0 = np.clip(q0, model.lower, model.upper)
    out = excursion(model, q0, bounds.SLOW_STEP_RAD)
    return validated(chain(plan_move(q0, out, limits), plan_move(out, q0, limits)), model, "slow motion")


def stop_move(model: ArmModel, q0: NDArray[np.float64]) -> JointTrajectory:
    """The move that Stop interrupts (module docstring)."""
    f = bounds.STOP_LIMIT_FRACTION
    q0 = np.clip(q0, model.lower, model.upper)
    goal = excursion(model, q0, bounds.STOP_MOVE_RAD)
    return validated(plan_move(q0, goal, model.limits.scaled(f, f, f)), model, "move for the Stop")


def time_scaled(traj: JointTrajectory, scale: float) -> JointTrajectory:
    """`traj` run `scale` times slower (module docstring), resampled at its original 1 ms: the
    scaled samples every `scale` ms are interpolated (cubic Hermite, `JointTrajectory.sample`) onto
    a 1 kHz grid, so the driver gets a 1 kHz trajectory still."""
    scaled = JointTrajectory(traj.times * scale, traj.positions, traj.velocities / scale, traj.accelerations / scale**2)
    dt = traj.dt
    start, end = float(scaled.times[0]), float(scaled.times[-1])
    # the grid's points from the start, those closer than 0.2 dt to the end left out, then the end
    # itself: the last sample is the end's state (at rest), never a point a fraction of a
    # millisecond before it (the interpolant's acceleration there broke the validator's rest check)
    grid = start + dt * np.arange(math.ceil((end - start) / dt) + 1, dtype=np.float64)
    grid = np.append(grid[grid < end - 0.2 * dt], end)
    q, dq, ddq = scaled.sample(grid)
    return JointTrajectory(grid, q, dq, ddq)


def planned_throw(model: ArmModel, q0: NDArray[np.float64], ball: Ball | None = None) -> ValidatedThrow:
    """The simulated operator's throw to the middle of the arm's training area from q0, validated
    (module docstring). ThrowingError when the arm cannot throw (no throwing section in its spec)
    or its model reaches no target of its area."""
    area = training_area(model)
    near, z = min(area.x), float(np.mean(area.z))
    x = float(np.mean(area.x))
    q0 = np.clip(q0, model.lower, model.upper)
    for _ in range(REACH_TRIES + 1):
        try:
            params = solve_throw(model, (x, z), shape=shape_for(model), ball=ball)
            break
        except UnreachableTargetError as exc:
            unreachable = exc
            x = 0.5 * (x + near)
    else:
        raise ThrowingError(f"the model of arm {model.name!r} throws to no target of its training area ({unreachable})")
    plan = plan_throw(model, params, z, q1=float(q0[0]), ball=ball, q_start=q0, target=(x, z))
    return require_valid(plan, model)


def scaled_throw(model: ArmModel, q0: NDArray[np.float64], ball: Ball | None = None) -> ScaledThrow:
    """The planned throw from q0, slowed down (module docstring). ThrowingError as `planned_throw`."""
    throw = planned_throw(model, q0, ball)
    target = throw.target
    assert target is not None  # planned for one
    s = bounds.THROW_TIME_SCALE
    traj = validated(time_scaled(throw.trajectory, s), model, "scaled throw")
    return ScaledThrow(traj, float(throw.release_time) * s, (float(target[0]), float(target[1])), s)


@dataclass(frozen=True)
class SpeedMotion:
    """The throwing-speed motion: `windup` (the slow move from the arm's pose to the wind-up pose,
    validated), `throw` (validated, from the wind-up pose at rest), `joints` (the throwing joints'
    indices), `planned_speed` (their release speeds, rad/s, the throw's peak), `release_time` (s,
    on the throw's axis)."""

    windup: JointTrajectory
    throw: JointTrajectory
    joints: tuple[int, ...]
    planned_speed: NDArray[np.float64]
    release_time: float


def throwing_speed(model: ArmModel, q0: NDArray[np.float64], ball: Ball | None = None) -> SpeedMotion:
    """The throwing-speed motion from q0 (module docstring). ThrowingError when the arm cannot
    throw or the validator refuses the throw, AppError when it refuses the move to the wind-up
    pose (nothing moves)."""
    shape = shape_for(model)
    mov, _, _ = shape.joint_layout(model)
    T = shape.acceleration_time
    # the fastest release the acceleration phase allows within the acceleration and jerk limits
    # (its peaks, 15/8 |dq|/T and 10/sqrt(3) |dq|/T^2: `representation`), as the operator's
    speed = np.minimum.reduce(
        [
            bounds.THROW_SPEED_FRACTION * model.velocity_limit[mov],
            model.acceleration_limit[mov] * T / ACCEL_PEAK_FACTOR,
            model.jerk_limit[mov] * T**2 / JERK_PEAK_FACTOR,
        ]
    )
    sign = directions(model)
    behind = 0.5 * T * speed + WIND_UP_ROOM_RAD
    ahead = np.full(shape.n, FOLLOW_THROUGH_ROOM_RAD)
    lo = model.lower[mov] + np.where(sign > 0, behind, ahead)
    hi = model.upper[mov] - np.where(sign > 0, ahead, behind)
    preferred = np.asarray(nominal_release(model), dtype=float)
    params = ThrowParameters(np.clip(preferred, lo, np.maximum(lo, hi)), sign * speed)
    q0 = np.clip(q0, model.lower, model.upper)
    q_windup = shape.full_q(model, shape.windup(params), float(q0[0]))
    plan = plan_throw(model, params, 0.0, q1=float(q0[0]), shape=shape, ball=ball)
    throw = require_valid(plan, model)
    return SpeedMotion(
        slow_move(model, q0, q_windup),
        throw.trajectory,
        tuple(int(j) for j in mov),
        speed,
        float(throw.release_time),
    )
