"""The independent limit validator: the only way to an executable throw (`ValidatedThrow`).

Independent of the planning: it uses neither `wiithrow.throwing.limiting` nor Ruckig, only the sampled
trajectory (times t_k, positions q_k, velocities dq_k, accelerations ddq_k) and the arm (its limits
and its kinematic model). Every sample of every joint is checked against:

- position:      lower - tol <= q_k <= upper + tol
- velocity:      |dq_k| <= m v_max;  acceleration: |ddq_k| <= a_max     (the given samples; m the
  velocity margin: 1 for `validate`'s plain limits, `VELOCITY_MARGIN` = 95 % for a throw)
- finite differences, each a weighted mean of the derivative it estimates, so bounded by that
  derivative's limit for any trajectory that respects it (Peano kernels of divided differences are
  positive; needs q in C^2 for the third difference, which jerk-limited trajectories are), also for
  non-uniform spacing:
      d1_k = (q_{k+1} - q_k) / h_k                          |d1| <= m v_max (mean velocity)
      d2_k = 2 (d1_{k+1} - d1_k) / (t_{k+2} - t_k)            |d2| <= a_max   (2! q[t_k..t_k+2])
      d3_k = 3 (d2_{k+1} - d2_k) / (t_{k+3} - t_k)            |d3| <= j_max   (3! q[t_k..t_k+3])
      (dq_{k+1} - dq_k) / h_k <= a_max,   (ddq_{k+1} - ddq_k) / h_k <= j_max
- floor: every collision point of the arm (`ArmModel.collision_points`: the moving joint origins,
  flange, marker, ball), at every sample, at least `floor_margin` (default 0.05 m, about a link
  radius) above z = 0 of `base`;
- the trajectory starts and ends at rest (|dq|, |ddq| <= rest tolerance);
- for a throw (`require_valid`): the release time is a sample, and the trajectory's state there
  is the plan's release state.

Tolerances (`Tolerances`) only absorb floating-point round-off: relative 1e-9 on every bound plus
absolute terms that grow with the order of the difference (round-off of an order-m difference of
angles ~1 rad is ~ 2^m eps / h^m: 1e-9 rad/s, 1e-6 rad/s^2, 1e-3 rad/s^3 cover h >= 0.2 ms).

Collision points are computed for all samples at once by the validator's own vectorized forward
kinematics of the arm's Pinocchio model (joint placements composed with the revolute joints'
rotations), equal to `ArmModel.collision_points` to round-off (tested); an arm with another joint
type falls back to calling `collision_points` per sample.
"""

from __future__ import annotations

import weakref
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Protocol

import numpy as np
from numpy.typing import ArrayLike, NDArray

from wiithrow.robot import ArmModel, JointTrajectory
from wiithrow.throwing.errors import TrajectoryRejected
from wiithrow.throwing.forward import PredictedLanding
from wiithrow.throwing.release import ReleaseState
from wiithrow.throwing.representation import VELOCITY_MARGIN, ThrowParameters

_TOKEN = object()  # only this module can build a ValidatedThrow


class PlannedThrow(Protocol):
    """What the validator and a `ValidatedThrow` read of a planned throw (`limiting.ThrowPlan` is
    one): `require_valid` itself reads only `trajectory`, `release_time`, `release` (q, dq) and
    `target`."""

    @property
    def trajectory(self) -> JointTrajectory: ...
    @property
    def release_time(self) -> float: ...
    @property
    def release(self) -> ReleaseState: ...
    @property
    def predicted(self) -> PredictedLanding: ...
    @property
    def target(self) -> tuple[float, float] | None: ...
    @property
    def q1(self) -> float: ...
    @property
    def params(self) -> ThrowParameters: ...
    @property
    def landing_height(self) -> float: ...


@dataclass(frozen=True)
class Tolerances:
    """Slack of the checks (module docstring): `relative` on every bound, absolute per quantity."""

    relative: float = 1e-9
    position: float = 1e-9  # rad
    velocity: float = 1e-9  # rad/s
    acceleration: float = 1e-6  # rad/s^2
    jerk: float = 1e-3  # rad/s^3
    rest: float = 1e-6  # rad/s and rad/s^2 at the start and the end
    release: float = 1e-9  # rad and rad/s between the release sample and the plan's release state


@dataclass(frozen=True)
class Violation:
    """One violated check: `check` (e.g. "velocity", "jerk (third difference of positions)",
    "floor"), `joint` (joint name, or the collision point's name for "floor"), `time` (s) of the
    first offending sample, `value` and `bound` (SI units; for "floor" the height above z = 0 of
    base and the required clearance), `count` of offending samples of this check and joint."""

    check: str
    joint: str
    time: float
    value: float
    bound: float
    count: int = 1

    def __str__(self) -> str:
        return (
            f"{self.check} of {self.joint} at t = {self.time:.4f} s: {self.value:.6g} beyond {self.bound:.6g}"
            f"{f' ({self.count} samples)' if self.count > 1 else ''}"
        )


@dataclass(frozen=True)
class ValidationReport:
    """The validator's verdict: `ok`; `violations` (the first per check and joint, in time order);
    `n_samples`; `checks` (the names of the checks run); `min_clearance` (m, lowest collision point
    above z = 0 of base); `floor_margin` (m); `tolerances`."""

    ok: bool
    violations: tuple[Violation, ...]
    n_samples: int
    checks: tuple[str, ...]
    min_clearance: float
    floor_margin: float
    tolerances: Tolerances = field(default_factory=Tolerances)

    def summary(self, first: int = 5) -> str:
        """One line: OK, or the first `first` violations."""
        if self.ok:
            return f"OK: {self.n_samples} samples pass {len(self.checks)} checks (clearance {self.min_clearance:.3f} m)"
        more = len(self.violations) - first
        return (
            f"{len(self.violations)} violation(s): "
            + "; ".join(str(v) for v in self.violations[:first])
            + (f"; and {more} more" if more > 0 else "")
        )


class ValidatedThrow:
    """An executable throw: a plan that passed `require_valid`. Only the validator builds one.

    Bring the arm to `start_pose` at rest, then command `trajectory` (e.g.
    `SimulatedArm.command_trajectory`); the ball is released at `release_time` on its axis.
    """

    __slots__ = ("plan", "report")

    def __init__(self, plan: PlannedThrow, report: ValidationReport, *, _token: object = None) -> None:
        if _token is not _TOKEN:
            raise TypeError("a ValidatedThrow is only made by wiithrow.throwing.validator.require_valid(plan, arm)")
        self.plan = plan  # the ThrowPlan it was made from
        self.report = report  # the ValidationReport that passed it

    @property
    def trajectory(self) -> JointTrajectory:
        """All joints, from rest to rest, sampled every 1 ms (the release and the end exact samples)."""
        return self.plan.trajectory

    @property
    def start_pose(self) -> NDArray[np.float64]:
        """(nq,) the trajectory's first position (rad): the arm must be there, at rest, before it starts."""
        return self.plan.trajectory.start[0]

    @property
    def release_time(self) -> float:
        """Release time (s) on the trajectory's time axis."""
        return self.plan.release_time

    @property
    def release(self) -> ReleaseState:
        """The intended release state (`release.ReleaseState`: joints; ball position and velocity in base)."""
        return self.plan.release

    @property
    def predicted(self) -> PredictedLanding:
        """The noise-free landing (`forward.PredictedLanding`: in base and in link1)."""
        return self.plan.predicted

    @property
    def target(self) -> tuple[float, float] | None:
        """The target (x, z) in link1 (m), or None."""
        return self.plan.target

    @property
    def q1(self) -> float:
        """Joint 1's angle (rad) during the throw."""
        return self.plan.q1

    @property
    def params(self) -> ThrowParameters:
        """The throw parameters (`representation.ThrowParameters`)."""
        return self.plan.params

    @property
    def landing_height(self) -> float:
        """The height (m, base = link1) the landing is predicted at."""
        return self.plan.landing_height

    def __repr__(self) -> str:
        t = self.plan.target
        return (
            f"ValidatedThrow(target={t}, release at {self.plan.release_time:.3f} s, "
            f"{self.plan.trajectory.times.size} samples, {self.report.summary()})"
        )


# ----- vectorized forward kinematics of the collision points -------------------------------------


_AXES = {"JointModelRX": (1.0, 0.0, 0.0), "JointModelRY": (0.0, 1.0, 0.0), "JointModelRZ": (0.0, 0.0, 1.0)}


class _Kinematics:
    """The constant data of an arm's forward kinematics for `collision_points_batch` (cached per arm)."""

    def __init__(self, arm: ArmModel) -> None:
        m = arm.model
        self.ok = True
        # (parent, q index, P, P K, P K^2, translation) per joint 1..njoints-1
        self.joints: list[
            tuple[int, int, NDArray[np.float64], NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]
        ] = []
        for j in range(1, m.njoints):
            short = m.joints[j].shortname()
            if short in _AXES:
                axis = np.array(_AXES[short])
            elif short == "JointModelRevoluteUnaligned":
                axis = np.asarray(m.joints[j].extract().axis, dtype=float)
            else:
                self.ok = False
                return
            x, y, z = axis
            K = np.array([[0.0, -z, y], [z, 0.0, -x], [-y, x, 0.0]])
            P = np.array(m.jointPlacements[j].rotation)
            self.joints.append(
                (
                    int(m.parents[j]),
                    int(m.idx_qs[j]),
                    P[:, :, None],
                    (P @ K)[:, :, None],
                    (P @ K @ K)[:, :, None],
                    np.array(m.jointPlacements[j].translation),
                )
            )
        names = arm.collision_point_names
        n_joint = len(names) - 3
        self.points: list[tuple[int, NDArray[np.float64]]] = [
            (int(m.getJointId(n)), np.zeros(3)) for n in names[:n_joint]
        ]
        for frame in names[n_joint:]:
            f = m.frames[arm.frame_id(frame)]
            self.points.append((int(f.parentJoint), np.array(f.placement.translation)))


_KINEMATICS: weakref.WeakKeyDictionary[ArmModel, _Kinematics] = weakref.WeakKeyDictionary()


def collision_points_batch(arm: ArmModel, Q: ArrayLike) -> NDArray[np.float64]:
    """(T, K, 3) collision points in `base` for configurations Q (T, nq), the rows of
    `arm.collision_points` (names `arm.collision_point_names`)."""
    Q = np.asarray(Q, dtype=np.float64)
    kin = _KINEMATICS.get(arm)
    if kin is None:
        kin = _KINEMATICS[arm] = _Kinematics(arm)
    if not kin.ok:  # another joint type: the model's own kinematics, one sample at a time
        return np.array([arm.collision_points(q) for q in Q])
    # layout (3, 3, T) and (3, T): the sample axis last, so the stacked products are fast einsums
    QT = np.ascontiguousarray(Q.T)
    S, C = np.sin(QT), 1.0 - np.cos(QT)
    R: list[NDArray[np.float64] | None] = [None]  # None: the identity (the root)
    p: list[NDArray[np.float64]] = [np.zeros((3, 1))]
    for parent, iq, P, PK, PK2, tp in kin.joints:
        # P Rot(axis, q) = P + sin(q) P K + (1 - cos(q)) P K^2  (Rodrigues; K the axis' cross-product matrix)
        M = P + PK * S[iq] + PK2 * C[iq]
        Rp = R[parent]
        if Rp is None:
            p.append(p[parent] + tp[:, None])
            R.append(M)
        else:
            p.append(p[parent] + np.einsum("ilt,l->it", Rp, tp))
            R.append(np.einsum("ilt,lkt->ikt", Rp, M))
    out = np.empty((3, len(kin.points), Q.shape[0]))
    for k, (j, tf) in enumerate(kin.points):
        Rj = R[j]
        out[:, k] = p[j] if Rj is None or not tf.any() else p[j] + np.einsum("ilt,l->it", Rj, tf)
    return out.transpose(2, 1, 0)


# ----- checks ------------------------------------------------------------------------------------


def _bound_check(
    out: list[Violation],
    check: str,
    values: NDArray[np.float64],
    bound: NDArray[np.float64],
    abs_tol: float,
    rel: float,
    times: NDArray[np.float64],
    names: Sequence[str],
) -> None:
    """Append a Violation per joint whose |values[:, j]| exceeds bound[j] (1 + rel) + abs_tol."""
    if values.size == 0:
        return
    bad = np.abs(values) > bound * (1.0 + rel) + abs_tol
    if not bad.any():
        return
    for j in np.flatnonzero(bad.any(axis=0)):
        k = int(np.argmax(bad[:, j]))
        out.append(
            Violation(check, names[int(j)], float(times[k]), float(values[k, j]), float(bound[j]), int(bad[:, j].sum()))
        )


def validate(
    trajectory: JointTrajectory,
    arm: ArmModel,
    *,
    floor_margin: float = 0.05,
    tolerances: Tolerances | None = None,
    velocity_margin: float = 1.0,
) -> ValidationReport:
    """Check every sample of `trajectory` against every limit of `arm` and the floor (module
    docstring), velocities against `velocity_margin` times their limit; return the report
    (never raises for a violation)."""
    tol = tolerances or Tolerances()
    if not isinstance(trajectory, JointTrajectory):
        raise TrajectoryRejected(f"the validator needs a robot.JointTrajectory, got {type(trajectory).__name__}")
    if trajectory.nq != arm.nq:
        raise TrajectoryRejected(f"the trajectory has {trajectory.nq} joints, arm '{arm.name}' has {arm.nq}")
    t = trajectory.times
    q, dq, ddq = trajectory.positions, trajectory.velocities, trajectory.accelerations
    names = arm.joint_names
    rel = tol.relative
    v: list[Violation] = []
    checks: list[str] = []

    # positions
    checks.append("position")
    low = q < arm.lower - tol.position
    high = q > arm.upper + tol.position
    for j in np.flatnonzero((low | high).any(axis=0)):
        k = int(np.argmax(low[:, j] | high[:, j]))
        bound = arm.lower[j] if low[k, j] else arm.upper[j]
        v.append(
            Violation(
                "position", names[j], float(t[k]), float(q[k, j]), float(bound), int((low[:, j] | high[:, j]).sum())
            )
        )
    # given samples
    checks += ["velocity", "acceleration"]
    v_bound = velocity_margin * arm.velocity_limit
    _bound_check(v, "velocity", dq, v_bound, tol.velocity, rel, t, names)
    _bound_check(v, "acceleration", ddq, arm.acceleration_limit, tol.acceleration, rel, t, names)
    # finite differences
    if t.size > 1:
        h = np.diff(t)[:, None]
        d1 = np.diff(q, axis=0) / h
        checks += [
            "velocity (first difference of positions)",
            "acceleration (difference of velocities)",
            "jerk (difference of accelerations)",
        ]
        _bound_check(v, checks[-3], d1, v_bound, tol.velocity, rel, t, names)
        _bound_check(v, checks[-2], np.diff(dq, axis=0) / h, arm.acceleration_limit, tol.acceleration, rel, t, names)
        _bound_check(v, checks[-1], np.diff(ddq, axis=0) / h, arm.jerk_limit, tol.jerk, rel, t, names)
        if t.size > 2:
            d2 = 2.0 * np.diff(d1, axis=0) / (t[2:] - t[:-2])[:, None]
            checks.append("acceleration (second difference of positions)")
            _bound_check(v, checks[-1], d2, arm.acceleration_limit, tol.acceleration, rel, t, names)
            if t.size > 3:
                d3 = 3.0 * np.diff(d2, axis=0) / (t[3:] - t[:-3])[:, None]
                checks.append("jerk (third difference of positions)")
                _bound_check(v, checks[-1], d3, arm.jerk_limit, tol.jerk, rel, t, names)
    # rest at both ends
    checks.append("rest at start and end")
    for when, k in (("start", 0), ("end", -1)):
        for what, a in (("velocity", dq), ("acceleration", ddq)):
            bad = np.abs(a[k]) > tol.rest
            for j in np.flatnonzero(bad):
                v.append(Violation(f"rest at the {when} ({what})", names[j], float(t[k]), float(a[k, j]), tol.rest))
    # floor
    checks.append("floor")
    pts = collision_points_batch(arm, q)
    z = pts[:, :, 2]
    bad = z < floor_margin
    pnames = arm.collision_point_names
    for i in np.flatnonzero(bad.any(axis=0)):
        k = int(np.argmax(bad[:, i]))
        v.append(Violation("floor", pnames[i], float(t[k]), float(z[k, i]), float(floor_margin), int(bad[:, i].sum())))
    v.sort(key=lambda x: (x.time, x.check, x.joint))
    return ValidationReport(not v, tuple(v), int(t.size), tuple(checks), float(z.min()), float(floor_margin), tol)


def require_valid(
    plan: PlannedThrow,
    arm: ArmModel,
    *,
    floor_margin: float = 0.05,
    tolerances: Tolerances | None = None,
    velocity_margin: float = VELOCITY_MARGIN,
) -> ValidatedThrow:
    """Validate a throw plan (anything with `trajectory`, `release_time` and `release` (q, dq)) and
    return the executable `ValidatedThrow`; raise TrajectoryRejected naming the first violations
    (all of them in its `report`). Every sample's speed is held to `velocity_margin` of its limit
    (95 %: the margin of the release velocity holds for the whole throw)."""
    tol = tolerances or Tolerances()
    traj = plan.trajectory
    report = validate(traj, arm, floor_margin=floor_margin, tolerances=tol, velocity_margin=velocity_margin)
    extra: list[Violation] = []
    k = int(np.argmin(np.abs(traj.times - plan.release_time)))
    if traj.times[k] != plan.release_time:
        extra.append(
            Violation(
                "release time is a sample", "-", float(plan.release_time), float(traj.times[k] - plan.release_time), 0.0
            )
        )
    else:
        for what, a, b in (
            ("release position", traj.positions[k], plan.release.q),
            ("release velocity", traj.velocities[k], plan.release.dq),
        ):
            err = np.abs(a - np.asarray(b))
            for j in np.flatnonzero(err > tol.release):
                extra.append(Violation(what, arm.joint_names[j], float(plan.release_time), float(err[j]), tol.release))
    if extra:
        report = ValidationReport(
            False,
            tuple(sorted(report.violations + tuple(extra), key=lambda x: x.time)),
            report.n_samples,
            report.checks + ("release state",),
            report.min_clearance,
            report.floor_margin,
            tol,
        )
    if not report.ok:
        tgt = getattr(plan, "target", None)
        raise TrajectoryRejected(
            f"throw{'' if tgt is None else f' to ({tgt[0]:.3f}, {tgt[1]:.3f}) m'} rejected by the validator: "
            f"{report.summary()}",
            report,
        )
    return ValidatedThrow(plan, report, _token=_TOKEN)
