"""Ruckig limiting: throw parameters -> the throw's joint trajectory (a `ThrowPlan`), sampled at 1 ms.

Ruckig 0.19 (community) plans state-to-state only, so the reference of the acceleration phase
(`ThrowShape.reference`) is followed by chaining segments through its knots (every
`knot_interval`, position, velocity and acceleration of the reference at each knot, Ruckig's
`minimum_duration` = the knot interval, time synchronization): each segment starts exactly where the
previous one ended, and the last ends exactly in the release state (q_r, dq_r, 0). Since the
reference itself is within the limits (`ThrowShape.check`), every segment takes exactly the knot
interval, and the release is at t_r = T. After it, Ruckig's velocity interface brakes every moving
joint to rest as fast as the limits allow (the follow-through; not synchronized). Joint 1 holds
q1, the held joints their angles. An optional prelude moves the arm from a start pose at rest to
the wind-up pose (synchronized, time-optimal).

Ruckig enforces velocity, acceleration and jerk limits (and position limits for the state-to-state
segments) within each segment. Its velocity bound is the shape's margin of the limit (95 %,
`representation.VELOCITY_MARGIN`) in every segment, the prelude and the braking included, so the
margin the release velocity is held to holds for the whole trajectory (the prelude too, not
time-optimal at 100 %); a target velocity above it would be refused, which the representation
rules out (release velocities <= the margin).

Sampling: the Ruckig profiles (7 constant-jerk phases per joint and segment) are evaluated in
closed form with numpy, all samples at once,

    p = p_i + v_i tau + a_i tau^2 / 2 + j_i tau^3 / 6,  v = v_i + a_i tau + j_i tau^2 / 2,  a = a_i + j_i tau

(tau: time since the phase's start), on the grid t = k dt, with the release time and the end time
as exact samples (an interval shorter than 0.2 dt next to them is dropped, so intervals are in
[0.2 dt, 1.2 dt]). Nothing here makes the trajectory executable: that is the validator's job
(`wiithrow.throwing.validator.require_valid`).
"""

from __future__ import annotations

import threading
from dataclasses import dataclass
from itertools import accumulate

import numpy as np
import ruckig
from numpy.typing import ArrayLike, NDArray

from wiithrow.robot import ArmModel, JointTrajectory, LimitError
from wiithrow.throwing.arm_throwing import shape_for
from wiithrow.throwing.ballistics import Ball
from wiithrow.throwing.errors import InfeasibleThrowError, ThrowingError
from wiithrow.throwing.forward import PredictedLanding, landing_from_release
from wiithrow.throwing.release import ReleaseState, release_state
from wiithrow.throwing.representation import ThrowParameters, ThrowShape

#: The release sample must match the intended release state to this (rad, rad/s).
RELEASE_TOLERANCE = 1e-9


@dataclass(frozen=True)
class ThrowPlan:
    """A planned, NOT yet validated throw (only `validator.require_valid` makes it executable).

    `trajectory`: all joints, sampled every `dt` s from t = 0 (rest) to the end of the follow-
    through (rest); `release_time` (s) on its axis, an exact sample; `release`: the intended
    release state (joints and ball in `base`); `params`, `shape`, `q1` (rad), `landing_height`
    (m); `predicted`: the noise-free landing (`base` and `link1`); `target` (x, z) in link1 or None.
    """

    trajectory: JointTrajectory
    release_time: float
    release: ReleaseState
    params: ThrowParameters
    shape: ThrowShape
    q1: float
    landing_height: float
    predicted: PredictedLanding
    target: tuple[float, float] | None = None
    ball: Ball = Ball()  # noqa: RUF009 (a frozen dataclass: one shared default is safe)

    @property
    def release_index(self) -> int:
        """Index of the release sample in the trajectory."""
        return int(np.argmin(np.abs(self.trajectory.times - self.release_time)))


# ----- Ruckig segments ---------------------------------------------------------------------------

#: One joint's profile in a segment: its 8 phase start times (local), and each phase's jerk and
#: start acceleration, velocity and position.
_Phases = tuple[list[float], list[float], list[float], list[float], list[float]]
#: A joint state (q, dq, ddq), each (n,).
_State = tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]


class _Segment:
    """One Ruckig trajectory starting at global time `start`, and its phase table (module docstring):
    per joint, the 8 phase start times (local; the 8th is the profile's end, after which the state
    continues with zero jerk), jerks and start states; None if a profile has a brake or acceleration
    pre-phase (then it is evaluated with Ruckig's at_time)."""

    __slots__ = ("duration", "start", "table", "traj")

    def __init__(self, traj: ruckig.Trajectory, start: float) -> None:
        self.traj = traj
        self.start = start
        self.duration = float(traj.duration)
        rows: list[_Phases] = []
        for pr in traj.profiles[0]:
            if pr.brake.duration > 0 or pr.accel.duration > 0:
                break
            rows.append((list(accumulate(pr.t, initial=0.0)), pr.j + [0.0], pr.a, pr.v, pr.p))
        self.table: list[_Phases] | None = rows if len(rows) == len(traj.profiles[0]) else None

    def evaluate(self, t: ArrayLike) -> _State:
        """(p, v, a), each (len(t), n), at segment-local times t."""
        return _evaluate([self], np.asarray(t, dtype=float) + self.start)


class _Planner:
    """Reusable Ruckig objects for n degrees of freedom."""

    def __init__(self, n: int) -> None:
        self.n = n
        self.otg = ruckig.Ruckig(n)
        self.inp = ruckig.InputParameter(n)

    def _calculate(self, what: str) -> ruckig.Trajectory:
        traj = ruckig.Trajectory(self.n)
        try:
            result = self.otg.calculate(self.inp, traj)
        except ruckig.RuckigError as exc:
            raise LimitError(f"{what}: Ruckig refused the input: {str(exc).strip()}") from None
        if result not in (ruckig.Result.Working, ruckig.Result.Finished):
            raise InfeasibleThrowError(f"{what}: Ruckig could not plan it ({result.name})")
        return traj

    def move(
        self,
        s0: _State,
        s1: _State,
        vmax: NDArray[np.float64],
        amax: NDArray[np.float64],
        jmax: NDArray[np.float64],
        lower: NDArray[np.float64],
        upper: NDArray[np.float64],
        min_duration: float | None,
        what: str,
    ) -> ruckig.Trajectory:
        inp = self.inp
        inp.control_interface = ruckig.ControlInterface.Position
        inp.synchronization = ruckig.Synchronization.Time
        inp.current_position, inp.current_velocity, inp.current_acceleration = s0
        inp.target_position, inp.target_velocity, inp.target_acceleration = s1
        inp.max_velocity, inp.max_acceleration, inp.max_jerk = vmax, amax, jmax
        inp.min_position, inp.max_position = lower, upper
        inp.minimum_duration = min_duration
        return self._calculate(what)

    def stop(
        self, s0: _State, vmax: NDArray[np.float64], amax: NDArray[np.float64], jmax: NDArray[np.float64]
    ) -> ruckig.Trajectory:
        inp = self.inp
        inp.control_interface = ruckig.ControlInterface.Velocity
        inp.synchronization = ruckig.Synchronization.No
        inp.current_position, inp.current_velocity, inp.current_acceleration = s0
        inp.target_velocity, inp.target_acceleration = np.zeros(self.n), np.zeros(self.n)
        inp.max_velocity, inp.max_acceleration, inp.max_jerk = vmax, amax, jmax
        inp.minimum_duration = None
        return self._calculate("follow-through")


_PLANNERS = threading.local()  # Ruckig objects are reused, one set per thread


def _planner(n: int) -> _Planner:
    cache = getattr(_PLANNERS, "by_dofs", None)
    if cache is None:
        cache = _PLANNERS.by_dofs = {}
    p = cache.get(n)
    if p is None:
        p = cache[n] = _Planner(n)
    return p


def _grid(start: float, end: float, dt: float) -> NDArray[np.float64]:
    """start, start + dt, ... and end exactly; a last interval < 0.2 dt is merged into the previous one."""
    k = np.arange(int(np.floor((end - start) / dt + 1e-9)) + 1)
    t = start + k * dt
    t = t[t < end - 0.2 * dt]
    return np.append(t, end)


def _evaluate(segments: list[_Segment], times: NDArray[np.float64]) -> _State:
    """Sample chained segments at sorted global times: each time goes to the last phase (over all
    segments) starting at or before it; one searchsorted and a few array operations per joint."""
    n = segments[0].traj.degrees_of_freedom
    P, V, A = (np.empty((times.size, n)) for _ in range(3))
    tables = [seg.table for seg in segments if seg.table is not None]
    if len(tables) < len(segments):  # rare: fall back to Ruckig's at_time
        starts = np.array([s.start for s in segments])
        idx = np.clip(np.searchsorted(starts, times, side="right") - 1, 0, len(segments) - 1)
        for k, tk in enumerate(times):
            seg = segments[idx[k]]
            P[k], V[k], A[k] = seg.traj.at_time(float(tk - seg.start))
        return P, V, A
    for d in range(n):
        t0: list[float] = []
        j: list[float] = []
        a: list[float] = []
        v: list[float] = []
        p: list[float] = []
        for seg, table in zip(segments, tables):
            st, sj, sa, sv, sp = table[d]
            t0.extend(x + seg.start for x in st)
            j.extend(sj)
            a.extend(sa)
            v.extend(sv)
            p.extend(sp)
        t0a = np.array(t0)
        i = np.searchsorted(t0a, times, side="right") - 1
        np.clip(i, 0, t0a.size - 1, out=i)
        tau = times - t0a[i]
        jj, ai, vi = np.array(j)[i], np.array(a)[i], np.array(v)[i]
        A[:, d] = ai + jj * tau
        V[:, d] = vi + tau * (ai + 0.5 * jj * tau)
        P[:, d] = np.array(p)[i] + tau * (vi + tau * (0.5 * ai + jj * tau / 6.0))
    return P, V, A


# ----- the plan ----------------------------------------------------------------------------------


def plan_throw(
    arm: ArmModel,
    params: ThrowParameters,
    landing_height: float,
    *,
    q1: float = 0.0,
    shape: ThrowShape | None = None,
    ball: Ball | None = None,
    dt: float = 0.001,
    q_start: ArrayLike | None = None,
    target: ArrayLike | None = None,
) -> ThrowPlan:
    """Plan the throw `params` as a limited joint trajectory (module docstring).

    `landing_height` (m): the height at which the predicted landing is computed (the target's z);
    `q1` (rad): joint 1's angle (the alignment); `q_start` (nq,): if given, a prelude moves the arm
    at rest from it to the wind-up pose (joint 1 to q1); otherwise the trajectory starts at the
    wind-up pose at rest (bring the arm there first); `shape` defaults to the arm's
    (`arm_throwing.shape_for`). Raises InfeasibleThrowError (a ThrowingError)
    if the parameters are not executable by construction, LimitError if Ruckig refuses an input.
    """
    shape = shape or shape_for(arm)
    ball = ball or Ball()
    if not dt > 0:
        raise ThrowingError(f"dt must be > 0, got {dt}")
    shape.check(arm, params, q1)
    mov, _, _ = shape.joint_layout(arm)
    n = shape.n
    v_bound = shape.velocity_margin * arm.velocity_limit  # the one margin, for every move
    vmax, amax, jmax = v_bound[mov], arm.acceleration_limit[mov], arm.jerk_limit[mov]
    lower, upper = arm.lower[mov], arm.upper[mov]
    q_windup = shape.full_q(arm, shape.windup(params), q1)

    # optional prelude: every joint, rest to rest
    t0 = 0.0
    prelude = None
    if q_start is not None:
        qs = arm.limits.check_position(q_start, "q_start")
        z = np.zeros(arm.nq)
        traj = _planner(arm.nq).move(
            (qs, z, z),
            (q_windup, z, z),
            v_bound,
            arm.acceleration_limit,
            arm.jerk_limit,
            arm.lower,
            arm.upper,
            None,
            "prelude to the wind-up pose",
        )
        prelude = _Segment(traj, 0.0)
        t0 = prelude.duration

    # acceleration phase: chain through the reference's knots
    _, Q, Vk, Ak = shape.knots(params)
    pl = _planner(n)
    segments: list[_Segment] = []
    start = t0
    for k in range(1, Q.shape[0]):
        traj = pl.move(
            (Q[k - 1], Vk[k - 1], Ak[k - 1]),
            (Q[k], Vk[k], Ak[k]),
            vmax,
            amax,
            jmax,
            lower,
            upper,
            shape.knot_interval,
            f"acceleration phase, knot {k}",
        )
        segments.append(_Segment(traj, start))
        start += segments[-1].duration
    t_release = start
    # follow-through: brake to rest
    stop = _Segment(pl.stop((Q[-1], Vk[-1], Ak[-1]), vmax, amax, jmax), t_release)
    segments.append(stop)
    t_end = t_release + stop.duration

    times = np.concatenate([_grid(0.0, t_release, dt), _grid(t_release, t_end, dt)[1:]])
    P = np.empty((times.size, arm.nq))
    V = np.zeros((times.size, arm.nq))
    A = np.zeros((times.size, arm.nq))
    in_throw = times >= t0
    Pm, Vm, Am = _evaluate(segments, times[in_throw])
    P[in_throw] = shape.full_q(arm, Pm, q1)
    V[np.ix_(in_throw, mov)] = Vm
    A[np.ix_(in_throw, mov)] = Am
    if prelude is not None:
        pre = ~in_throw
        P[pre], V[pre], A[pre] = prelude.evaluate(times[pre])
    trajectory = JointTrajectory(times, P, V, A)

    # the release sample is the intended release state
    k_rel = int(np.searchsorted(times, t_release))
    intended_q = shape.full_q(arm, params.q_release, q1)
    intended_dq = shape.full_dq(arm, params.dq_release)
    err = max(np.max(np.abs(P[k_rel] - intended_q)), np.max(np.abs(V[k_rel] - intended_dq)))
    if times[k_rel] != t_release or not err <= RELEASE_TOLERANCE:
        raise InfeasibleThrowError(f"the planned trajectory misses the release state by {err:.3g} (rad, rad/s)")
    release = release_state(arm, intended_q, intended_dq, t_release)
    predicted = landing_from_release(arm, release, landing_height, q1, ball)
    t = None if target is None else np.asarray(target, dtype=np.float64)
    tgt = None if t is None else (float(t[0]), float(t[1]))
    return ThrowPlan(
        trajectory, float(t_release), release, params, shape, float(q1), float(landing_height), predicted, tgt, ball
    )
