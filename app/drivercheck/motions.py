"""The motions `wiithrow check-driver` commands, each validated before the arm sees it.

Nothing moves the arm here but `Arm.command_trajectory` with a trajectory that passed the
throwing validator (`wiithrow.throwing.validator.validate`: every sample's position, velocity,
acceleration and jerk against the arm's limits, its finite differences, the floor, rest at both
ends), sampled at 1 ms:

* `slow_out_and_back`: every joint out by `bounds.SLOW_STEP_RAD` (away from its nearer limit)
  and back, Ruckig moves at `bounds.SLOW_LIMIT_FRACTION` of the limits;
* `stop_move`: every joint out by `bounds.STOP_MOVE_RAD` at `bounds.STOP_LIMIT_FRACTION` of the
  limits: the move that Stop interrupts;
* `scaled_throw`: a throw of the project's planner (`ThrowPlanner.plan`, validated by
  `require_valid`) to the middle of the library's trained area, from the arm's pose (its prelude
  to the wind-up pose included), time-scaled by `bounds.THROW_TIME_SCALE`:

      t' = s t,  q'(t') = q(t' / s),  dq' = dq / s,  ddq' = ddq / s^2   (jerk / s^3)

  the same path, gentler at every sample, and validated again as it is;
* `slow_move`: back to where the check started, at the slow fraction of the limits.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from wiithrow.app.drivercheck import bounds
from wiithrow.app.errors import AppError
from wiithrow.robot import ArmModel, JointTrajectory, plan_move
from wiithrow.throwing import ThrowLibrary, ThrowPlanner, TrainedArea
from wiithrow.throwing.validator import validate

#: A joint's excursion keeps this far (rad) from its limit.
LIMIT_CLEARANCE_RAD = 0.02


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


def scaled_throw(model: ArmModel, library: ThrowLibrary, q0: NDArray[np.float64]) -> ScaledThrow:
    """The planner's throw to the middle of the trained area from q0, slowed down (module
    docstring). ThrowingError when the library is not for this arm or the planner refuses."""
    planner = ThrowPlanner(model, library)
    area = TrainedArea(library.landings)
    target = area.vertices.mean(axis=0)
    q0 = np.clip(q0, model.lower, model.upper)
    throw = planner.plan(target, q1=float(q0[0]), q_start=q0)
    s = bounds.THROW_TIME_SCALE
    traj = validated(time_scaled(throw.trajectory, s), model, "scaled throw")
    return ScaledThrow(traj, float(throw.release_time) * s, (float(target[0]), float(target[1])), s)
