"""Sampled joint trajectories and their jerk-limited planning with Ruckig (community edition).

`JointTrajectory` holds uniformly or non-uniformly timed samples of q, dq, ddq and interpolates
between them. `plan_move` plans a time-optimal, jerk-limited state-to-state move (Ruckig's offline
`calculate`, then `at_time` at every `dt`); `plan_stop` brakes from any state to rest (Ruckig's
velocity interface with a zero target velocity). `check_trajectory` validates a trajectory against
joint limits, sample by sample and by finite differences of its positions.

Ruckig 0.19 (community) has no intermediate waypoints: to follow a reference through knots, chain
`plan_move` segments whose goal states carry velocities (`v_goal`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import ruckig
from numpy.typing import ArrayLike, NDArray

from wiithrow.robot.errors import LimitError, RobotError
from wiithrow.robot.limits import HasJointLimits, JointLimits


@dataclass(frozen=True)
class JointTrajectory:
    """Samples of a joint trajectory: `times` (T,) s strictly increasing; `positions`, `velocities`,
    `accelerations` (T, nq) in rad, rad/s, rad/s^2. Arrays are read-only copies.
    """

    times: NDArray[np.float64]
    positions: NDArray[np.float64]
    velocities: NDArray[np.float64]
    accelerations: NDArray[np.float64]

    def __post_init__(self) -> None:
        t = np.array(self.times, dtype=float).reshape(-1)
        if t.size < 1:
            raise RobotError("a JointTrajectory needs at least one sample")
        if not np.all(np.isfinite(t)) or np.any(np.diff(t) <= 0):
            raise RobotError("JointTrajectory times must be finite and strictly increasing")
        arrays: dict[str, NDArray[np.float64]] = {}
        for field in ("positions", "velocities", "accelerations"):
            a = np.array(getattr(self, field), dtype=float)
            if a.ndim != 2 or a.shape[0] != t.size:
                raise RobotError(f"JointTrajectory {field} must have shape ({t.size}, nq), got {a.shape}")
            if not np.all(np.isfinite(a)):
                raise RobotError(f"JointTrajectory {field} must be finite")
            arrays[field] = a
        if len({a.shape for a in arrays.values()}) != 1:
            raise RobotError("JointTrajectory positions, velocities and accelerations must have the same shape")
        for field, a in (("times", t), *arrays.items()):
            a.flags.writeable = False
            object.__setattr__(self, field, a)

    @property
    def nq(self) -> int:
        """Number of joints."""
        return int(self.positions.shape[1])

    @property
    def duration(self) -> float:
        """times[-1] - times[0] (s)."""
        return float(self.times[-1] - self.times[0])

    @property
    def dt(self) -> float:
        """The nominal sample interval (s): the median spacing of `times` (0 for one sample)."""
        return float(np.median(np.diff(self.times))) if self.times.size > 1 else 0.0

    def sample(self, t: ArrayLike) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
        """(q, dq, ddq) at time(s) `t` (on the `times` axis; clamped to its ends).

        q is a cubic Hermite interpolation of the positions and velocities of the two neighbouring
        samples; dq and ddq are linear interpolations. `t` scalar -> (nq,) each; (M,) -> (M, nq).
        """
        ts = np.asarray(t, dtype=float)
        scalar = ts.ndim == 0
        ts = np.clip(np.atleast_1d(ts), self.times[0], self.times[-1])
        if self.times.size == 1:
            out: list[NDArray[np.float64]] = [
                np.repeat(a[:1], ts.size, axis=0) for a in (self.positions, self.velocities, self.accelerations)
            ]
        else:
            i = np.clip(np.searchsorted(self.times, ts, side="right") - 1, 0, self.times.size - 2)
            h = (self.times[i + 1] - self.times[i])[:, None]
            s = (ts - self.times[i])[:, None] / h
            p0, p1 = self.positions[i], self.positions[i + 1]
            v0, v1 = self.velocities[i], self.velocities[i + 1]
            # Hermite basis: q(s) = h00 p0 + h10 h v0 + h01 p1 + h11 h v1
            h00, h10 = 2 * s**3 - 3 * s**2 + 1, s**3 - 2 * s**2 + s
            h01, h11 = -2 * s**3 + 3 * s**2, s**3 - s**2
            q = h00 * p0 + h10 * h * v0 + h01 * p1 + h11 * h * v1
            dq = (1 - s) * v0 + s * v1
            ddq = (1 - s) * self.accelerations[i] + s * self.accelerations[i + 1]
            out = [q, dq, ddq]
        if scalar:
            return out[0][0], out[1][0], out[2][0]
        return out[0], out[1], out[2]

    @property
    def start(self) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
        """(q, dq, ddq) of the first sample."""
        return self.positions[0], self.velocities[0], self.accelerations[0]

    @property
    def end(self) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
        """(q, dq, ddq) of the last sample."""
        return self.positions[-1], self.velocities[-1], self.accelerations[-1]


def _limits(arm_or_limits: JointLimits | HasJointLimits) -> JointLimits:
    if isinstance(arm_or_limits, JointLimits):
        return arm_or_limits
    lim = getattr(arm_or_limits, "limits", None)
    if isinstance(lim, JointLimits):
        return lim
    raise RobotError(f"expected an ArmModel or JointLimits, got {type(arm_or_limits).__name__}")


def _state(limits: JointLimits, v: ArrayLike | None, what: str) -> NDArray[np.float64]:
    return np.zeros(limits.n) if v is None else limits.vector(v, what)


def _sample(traj: ruckig.Trajectory, n: int, dt: float) -> JointTrajectory:
    """Sample a Ruckig trajectory at t = k dt for k dt < duration, and at t = duration (its end state).

    So all intervals are dt except the last one, which is shorter when the duration is not a
    multiple of dt: the end state (e.g. a release at speed) keeps its exact time.
    """
    duration = float(traj.duration)
    full = int(np.ceil(duration / dt - 1e-9))
    times = np.append(np.arange(full) * dt, duration) if duration > 0 else np.zeros(1)
    P, V, A = (np.empty((times.size, n)) for _ in range(3))
    for k, t in enumerate(times):
        P[k], V[k], A[k] = traj.at_time(t)
    return JointTrajectory(times, P, V, A)


def _calculate(inp: ruckig.InputParameter, n: int, what: str) -> ruckig.Trajectory:
    traj = ruckig.Trajectory(n)
    try:
        result = ruckig.Ruckig(n).calculate(inp, traj)
    except ruckig.RuckigError as exc:  # e.g. a target velocity above its limit
        raise LimitError(f"{what}: Ruckig refused the input: {str(exc).strip()}") from None
    if result not in (ruckig.Result.Working, ruckig.Result.Finished):
        raise RobotError(f"{what}: Ruckig could not plan it ({result.name}); check the limits and states")
    return traj


def plan_move(
    q_start: ArrayLike,
    q_goal: ArrayLike,
    arm_or_limits: JointLimits | HasJointLimits,
    dt: float = 0.001,
    v_start: ArrayLike | None = None,
    a_start: ArrayLike | None = None,
    v_goal: ArrayLike | None = None,
    *,
    min_duration: float | None = None,
) -> JointTrajectory:
    """Time-optimal jerk-limited move from (q_start, v_start, a_start) to (q_goal, v_goal, 0).

    All joints are synchronized to finish together (Ruckig's default), and the trajectory stays
    inside the position limits. Returns samples every `dt` s from t = 0, and the goal state at the
    end (the last interval may be shorter than dt). Raises LimitError (naming the joint) if the start or goal is outside the position limits
    or a start/goal velocity exceeds its limit; RobotError for bad shapes.
    """
    lim = _limits(arm_or_limits)
    if not dt > 0:
        raise RobotError(f"dt must be > 0, got {dt}")
    q0 = lim.check_position(q_start, "q_start")
    q1 = lim.check_position(q_goal, "q_goal")
    v0 = _state(lim, v_start, "v_start")
    a0 = _state(lim, a_start, "a_start")
    v1 = _state(lim, v_goal, "v_goal")
    lim.check_bound(v0, lim.velocity, "velocity", "v_start")
    lim.check_bound(v1, lim.velocity, "velocity", "v_goal")
    n = lim.n
    inp = ruckig.InputParameter(n)
    inp.current_position, inp.current_velocity, inp.current_acceleration = q0, v0, a0
    inp.target_position, inp.target_velocity, inp.target_acceleration = q1, v1, np.zeros(n)
    inp.max_velocity, inp.max_acceleration, inp.max_jerk = lim.velocity, lim.acceleration, lim.jerk
    inp.min_position, inp.max_position = lim.lower, lim.upper
    if min_duration is not None:
        inp.minimum_duration = float(min_duration)
    return _sample(_calculate(inp, n, "plan_move"), n, dt)


def plan_stop(
    q: ArrayLike, dq: ArrayLike, ddq: ArrayLike, arm_or_limits: JointLimits | HasJointLimits, dt: float = 0.001
) -> JointTrajectory:
    """Brake from (q, dq, ddq) to rest as fast as the velocity, acceleration and jerk limits allow.

    Ruckig's velocity interface with target velocity and acceleration 0; the joints are not
    synchronized (each stops as soon as it can). The position limits are not enforced (a joint
    racing towards its limit stops where physics lets it).
    """
    lim = _limits(arm_or_limits)
    n = lim.n
    inp = ruckig.InputParameter(n)
    inp.control_interface = ruckig.ControlInterface.Velocity
    inp.synchronization = ruckig.Synchronization.No
    inp.current_position = lim.vector(q, "q")
    inp.current_velocity = lim.vector(dq, "dq")
    inp.current_acceleration = lim.vector(ddq, "ddq")
    inp.target_velocity, inp.target_acceleration = np.zeros(n), np.zeros(n)
    inp.max_velocity, inp.max_acceleration, inp.max_jerk = lim.velocity, lim.acceleration, lim.jerk
    return _sample(_calculate(inp, n, "plan_stop"), n, dt)


def check_trajectory(
    traj: JointTrajectory, arm_or_limits: JointLimits | HasJointLimits, *, tol: float = 1e-6, check_jerk: bool = False
) -> None:
    """Raise LimitError (naming the joint and sample) if `traj` leaves the limits, else return None.

    Checks positions against the position limits, the sampled velocities and accelerations against
    their limits, and the finite differences of the samples: (q[k+1]-q[k])/dt_k against the velocity
    limit (a mean velocity), (dq[k+1]-dq[k])/dt_k against the acceleration limit, and if
    `check_jerk`, (ddq[k+1]-ddq[k])/dt_k against the jerk limit. `tol` is relative.
    """
    lim = _limits(arm_or_limits)
    if traj.nq != lim.n:
        raise RobotError(f"trajectory has {traj.nq} joints, the arm {lim.n}")
    bad = (traj.positions < lim.lower - tol) | (traj.positions > lim.upper + tol)
    if np.any(bad):
        k, j = np.argwhere(bad)[0]
        raise LimitError(
            f"trajectory: joint {lim.names[j]} position {traj.positions[k, j]:.4f} at t = {traj.times[k]:.3f} s "
            f"is outside [{lim.lower[j]:.4f}, {lim.upper[j]:.4f}]",
            joint=lim.names[j],
        )
    lim.check_bound(traj.velocities, lim.velocity, "velocity", "trajectory", tol)
    lim.check_bound(traj.accelerations, lim.acceleration, "acceleration", "trajectory", tol)
    if traj.times.size > 1:
        h = np.diff(traj.times)[:, None]
        lim.check_bound(
            np.diff(traj.positions, axis=0) / h, lim.velocity, "finite-difference velocity", "trajectory", tol
        )
        lim.check_bound(
            np.diff(traj.velocities, axis=0) / h, lim.acceleration, "finite-difference acceleration", "trajectory", tol
        )
        if check_jerk:
            lim.check_bound(np.diff(traj.accelerations, axis=0) / h, lim.jerk, "jerk", "trajectory", tol)
