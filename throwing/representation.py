"""How a throw is represented: a release state in joint space plus a fixed-shape acceleration phase.

Choice. A throw is a motion of the arm's throwing joints (its three pitch joints, all about axes
parallel to link1's y axis, so the ball stays in the plane y = 0 of link1: PA-10 S2, E1, W1; Panda
joints 2, 4, 6; UR5e shoulder_lift, elbow, wrist_1; the arm's spec names them, and
`wiithrow.throwing.arm_throwing.shape_for` builds its shape) with the other joints held (PA-10: S3
= E2 = W2 = 0; joint 1 holds the alignment angle q1, which is not a parameter). Its parameters are

    theta = (q_r, dq_r)   (6,): the release joint positions (rad) and velocities (rad/s)

of the moving joints. Why this rather than dynamic movement primitives (Ude et al. 2010):
- the release state alone determines the ball's flight, so theta -> landing is a smooth, low-
  dimensional map, and 25 trained throws suffice to regress its inverse over a 2D target area (a
  DMP has tens of weights per joint, mostly redundant for the landing, and its release state is only
  implicit, after integrating it);
- limit safety holds by construction: the release velocity is a parameter, kept below a margin
  (95 %) of the velocity limit (a Ruckig target velocity above the limit is refused), and the
  acceleration phase below has closed-form peaks, so a parameter check is a feasibility proof;
- regression over theta is still a regression of a whole movement, as with DMP weights: every
  parameter varies smoothly with the target when the training throws do (the simulated operator
  picks the least-effort throw, a smooth function of the target; see `wiithrow.throwing.operator`).

The acceleration phase (the "reference"), per moving joint, over a fixed duration T (s), s = t / T:

    dq(t)  = dq_r S(s),            S(s) = 10 s^3 - 15 s^4 + 6 s^5   (the minimum-jerk smoothstep)
    ddq(t) = dq_r / T  30 s^2 (1 - s)^2
    q(t)   = q_w + dq_r T (5/2 s^4 - 3 s^5 + s^6),       q_w = q_r - dq_r T / 2  (the wind-up pose)

It starts at rest with zero acceleration at the wind-up pose and ends at the release state with
zero acceleration (the joints are at peak speed at the release, so a release-time error changes the
joint velocities only to second order). Its peaks:

    max |ddq| = 15/8 |dq_r| / T,       max |dddq| = (10 / sqrt(3)) |dq_r| / T^2   (at s = 1/2 -+ 1/sqrt(12))

so with T = 0.32 s and |dq_r| <= 0.95 v_max (`VELOCITY_MARGIN`) the PA-10's default limits (a = v / 0.15 s,
j = a / 0.075 s, rounded) are met with at least 16 % (acceleration) and 37 % (jerk) to spare. (The
Panda's shoulder, 7.5 rad/s^2 for 2.175 rad/s, needs T = 0.48 s, its spec's, and still caps its
release speed at 7.5 T / (15/8) = 1.92 rad/s: the simulated operator keeps within both.)
After the release the limited trajectory brakes to rest (`wiithrow.throwing.limiting`).
"""

from __future__ import annotations

import math
import weakref
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from wiithrow.robot import ArmModel
from wiithrow.throwing.errors import InfeasibleThrowError, LibraryFormatError, ThrowingError

#: max over s of |d/ds of 30 s^2 (1-s)^2| = 60 |s (1-s) (1-2s)| = 10 / sqrt(3)
JERK_PEAK_FACTOR = 10.0 / math.sqrt(3.0)
#: max over s of 30 s^2 (1-s)^2 = 30/16
ACCEL_PEAK_FACTOR = 15.0 / 8.0

#: (moving joint indices, held joint indices, held angles) into an arm's joint vector.
JointLayout = tuple[NDArray[np.intp], NDArray[np.intp], NDArray[np.float64]]

_LAYOUTS: weakref.WeakKeyDictionary[ArmModel, dict[ThrowShape, JointLayout]] = weakref.WeakKeyDictionary()


#: The one velocity margin of a throw: no joint above 95 % of its velocity limit at any sample,
#: the release velocity (a parameter, checked by `ThrowShape.check`) and every move around it
#: (`limiting` gives Ruckig these bounds; `validator.require_valid` enforces them).
VELOCITY_MARGIN = 0.95


@dataclass(frozen=True, eq=False)
class ThrowParameters:
    """One throw: release positions `q_release` and velocities `dq_release` (rad, rad/s) of the
    shape's moving joints, in the order of `ThrowShape.moving_joints`."""

    q_release: NDArray[np.float64]
    dq_release: NDArray[np.float64]

    def __post_init__(self) -> None:
        q = np.array(self.q_release, dtype=float).reshape(-1)
        dq = np.array(self.dq_release, dtype=float).reshape(-1)
        if q.shape != dq.shape or q.size == 0:
            raise ThrowingError(f"q_release and dq_release must have the same length, got {q.shape} and {dq.shape}")
        if not (np.all(np.isfinite(q)) and np.all(np.isfinite(dq))):
            raise ThrowingError("throw parameters must be finite")
        q.flags.writeable = False
        dq.flags.writeable = False
        object.__setattr__(self, "q_release", q)
        object.__setattr__(self, "dq_release", dq)

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, ThrowParameters):
            return NotImplemented
        return bool(
            np.array_equal(self.q_release, other.q_release) and np.array_equal(self.dq_release, other.dq_release)
        )

    def __hash__(self) -> int:
        raise TypeError("unhashable type: 'ThrowParameters' (it holds arrays)")

    @property
    def vector(self) -> NDArray[np.float64]:
        """theta = (q_release, dq_release) as one (2n,) vector (for regression)."""
        return np.concatenate([self.q_release, self.dq_release])

    @classmethod
    def from_vector(cls, theta: ArrayLike) -> ThrowParameters:
        """The inverse of `vector`."""
        v = np.asarray(theta, dtype=float).reshape(-1)
        if v.size % 2:
            raise ThrowingError(f"a parameter vector has an even length (q then dq), got {v.size}")
        n = v.size // 2
        return cls(v[:n], v[n:])

    def to_dict(self) -> dict[str, list[float]]:
        return {"q_release": self.q_release.tolist(), "dq_release": self.dq_release.tolist()}

    @classmethod
    def from_dict(cls, d: Mapping[str, Any]) -> ThrowParameters:
        """The parameters in `d`, a JSON object (its values are checked here)."""
        try:
            return cls(d["q_release"], d["dq_release"])
        except (KeyError, TypeError) as exc:
            raise LibraryFormatError(f"bad throw parameters {d!r}: {exc}") from None


@dataclass(frozen=True)
class ThrowShape:
    """Settings of the representation (module docstring), shared by every throw of a library.
    The defaults are the PA-10's; another arm's shape is `arm_throwing.shape_for(arm)`, from its spec.

    `moving_joints`: the joints the throw moves; `held_joints`: (name, angle) pairs held during the
    throw (every other joint except joint 1); `acceleration_time` T (s); `knot_interval` (s): the
    spacing of the knots Ruckig limiting follows through the reference (T must be a multiple of it);
    `velocity_margin`: |dq_r| <= margin * v_max.
    """

    moving_joints: tuple[str, ...] = ("S2", "E1", "W1")
    held_joints: tuple[tuple[str, float], ...] = (("S3", 0.0), ("E2", 0.0), ("W2", 0.0))
    acceleration_time: float = 0.32
    knot_interval: float = 0.04
    velocity_margin: float = VELOCITY_MARGIN

    def __post_init__(self) -> None:
        object.__setattr__(self, "moving_joints", tuple(str(j) for j in self.moving_joints))
        object.__setattr__(self, "held_joints", tuple((str(n), float(v)) for n, v in self.held_joints))
        T, h = float(self.acceleration_time), float(self.knot_interval)
        if not (T > 0 and h > 0 and math.isfinite(T)):
            raise ThrowingError(f"acceleration_time and knot_interval must be > 0, got {T}, {h}")
        n = round(T / h)
        if n < 1 or abs(n * h - T) > 1e-9:
            raise ThrowingError(f"acceleration_time {T} s must be a multiple of knot_interval {h} s")
        if not 0 < self.velocity_margin <= 1:
            raise ThrowingError(f"velocity_margin must be in (0, 1], got {self.velocity_margin}")
        names = self.moving_joints + tuple(n for n, _ in self.held_joints)
        if len(set(names)) != len(names):
            raise ThrowingError(f"a joint is both moving and held, or listed twice: {names}")

    @property
    def n(self) -> int:
        """Number of moving joints."""
        return len(self.moving_joints)

    @property
    def n_knots(self) -> int:
        """Number of knot intervals in the acceleration phase, T / knot_interval."""
        return round(self.acceleration_time / self.knot_interval)

    # ----- joints -------------------------------------------------------------------------------

    def joint_layout(self, arm: ArmModel) -> JointLayout:
        """(moving indices, held indices, held angles) into the arm's joint vector; joint 1 (index 0)
        is in neither. Raises ThrowingError if the arm lacks a joint or one is unaccounted for.
        (Cached per arm and shape; the arrays are read-only.)"""
        per_arm = _LAYOUTS.setdefault(arm, {})
        layout = per_arm.get(self)
        if layout is None:
            layout = per_arm[self] = self._layout(arm)
        return layout

    def _layout(self, arm: ArmModel) -> JointLayout:
        names = list(arm.joint_names)
        try:
            mov = np.array([names.index(j) for j in self.moving_joints], dtype=int)
            held = np.array([names.index(j) for j, _ in self.held_joints], dtype=int)
        except ValueError:
            raise ThrowingError(
                f"arm '{arm.name}' (joints {names}) lacks a joint of the throw shape "
                f"{self.moving_joints} + {[j for j, _ in self.held_joints]}"
            ) from None
        covered = {0, *mov.tolist(), *held.tolist()}
        if covered != set(range(arm.nq)):
            raise ThrowingError(f"the throw shape must assign every joint of '{arm.name}' except joint 1: {names}")
        out: JointLayout = (mov, held, np.array([v for _, v in self.held_joints], dtype=np.float64))
        for a in out:
            a.flags.writeable = False
        return out

    def full_q(self, arm: ArmModel, q_moving: ArrayLike, q1: float) -> NDArray[np.float64]:
        """(..., nq) joint vectors: joint 1 = q1, held joints at their angles, moving joints = q_moving (..., n)."""
        mov, held, hv = self.joint_layout(arm)
        qm = np.asarray(q_moving, dtype=float)
        out = np.empty(qm.shape[:-1] + (arm.nq,))
        out[..., 0] = q1
        out[..., held] = hv
        out[..., mov] = qm
        return out

    def full_dq(self, arm: ArmModel, dq_moving: ArrayLike) -> NDArray[np.float64]:
        """(..., nq) joint velocities: zero except the moving joints."""
        mov, _, _ = self.joint_layout(arm)
        dm = np.asarray(dq_moving, dtype=float)
        out = np.zeros(dm.shape[:-1] + (arm.nq,))
        out[..., mov] = dm
        return out

    # ----- the reference ------------------------------------------------------------------------

    def windup(self, params: ThrowParameters) -> NDArray[np.float64]:
        """(n,) wind-up pose of the moving joints: q_w = q_r - dq_r T / 2."""
        return params.q_release - 0.5 * self.acceleration_time * params.dq_release

    def reference(
        self, params: ThrowParameters, t: ArrayLike
    ) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
        """(q, dq, ddq), each (len(t), n), of the acceleration phase at times t in [0, T] (clamped)."""
        T = self.acceleration_time
        s = np.clip(np.asarray(t, dtype=float).reshape(-1, 1) / T, 0.0, 1.0)
        dqr = params.dq_release[None, :]
        s2, s3 = s * s, s * s * s
        q = self.windup(params)[None, :] + dqr * T * s2 * s2 * (2.5 - 3.0 * s + s2)
        dq = dqr * s3 * (10.0 - 15.0 * s + 6.0 * s2)
        ddq = dqr / T * 30.0 * s2 * (1.0 - s) ** 2
        return q, dq, ddq

    def knots(
        self, params: ThrowParameters
    ) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
        """(times (N+1,), q, dq, ddq (N+1, n)): the reference at every knot_interval from 0 to T;
        the last knot is exactly the release state (q_r, dq_r, 0)."""
        times = np.arange(self.n_knots + 1, dtype=np.float64) * self.knot_interval
        q, dq, ddq = self.reference(params, times)
        q[-1], dq[-1], ddq[-1] = params.q_release, params.dq_release, 0.0
        return times, q, dq, ddq

    def peaks(self, params: ThrowParameters) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """(max |ddq|, max |dddq|) (n,) of the reference: 15/8 |dq_r|/T and 10/sqrt(3) |dq_r|/T^2."""
        T = self.acceleration_time
        a = np.abs(params.dq_release)
        return ACCEL_PEAK_FACTOR * a / T, JERK_PEAK_FACTOR * a / T**2

    def check(self, arm: ArmModel, params: ThrowParameters, q1: float = 0.0) -> None:
        """Raise InfeasibleThrowError unless the throw is executable by construction: |dq_r| <=
        margin v_max, the reference's peak acceleration and jerk within the limits, the wind-up and
        release poses (and q1) inside the position limits."""
        mov, _, _ = self.joint_layout(arm)
        if params.q_release.size != self.n:
            raise InfeasibleThrowError(f"the throw has {params.q_release.size} joints, the shape {self.n}")
        names = self.moving_joints
        vmax = self.velocity_margin * arm.velocity_limit[mov]
        bad = np.abs(params.dq_release) > vmax * (1 + 1e-12)
        if bad.any():
            j = int(np.argmax(bad))
            raise InfeasibleThrowError(
                f"release velocity of {names[j]} {params.dq_release[j]:.4f} rad/s exceeds "
                f"{self.velocity_margin:.0%} of its limit ({vmax[j]:.4f} rad/s); "
                "choose a target inside the trained area"
            )
        acc, jerk = self.peaks(params)
        for what, peak, lim in (
            ("acceleration", acc, arm.acceleration_limit[mov]),
            ("jerk", jerk, arm.jerk_limit[mov]),
        ):
            bad = peak > lim
            if bad.any():
                j = int(np.argmax(bad))
                raise InfeasibleThrowError(
                    f"the acceleration phase of {names[j]} peaks at {what} {peak[j]:.3f} above its limit "
                    f"{lim[j]:.3f}; lengthen acceleration_time (now {self.acceleration_time} s)"
                )
        for what, qm in (("wind-up", self.windup(params)), ("release", params.q_release)):
            q = self.full_q(arm, qm, q1)
            bad = (q < arm.lower) | (q > arm.upper)
            if bad.any():
                j = int(np.argmax(bad))
                raise InfeasibleThrowError(
                    f"the {what} pose puts joint {arm.joint_names[j]} at {q[j]:.4f} rad, outside "
                    f"[{arm.lower[j]:.4f}, {arm.upper[j]:.4f}]"
                )

    # ----- files --------------------------------------------------------------------------------

    def to_dict(self) -> dict[str, object]:
        return {
            "moving_joints": list(self.moving_joints),
            "held_joints": [[n, v] for n, v in self.held_joints],
            "acceleration_time": self.acceleration_time,
            "knot_interval": self.knot_interval,
            "velocity_margin": self.velocity_margin,
        }

    @classmethod
    def from_dict(cls, d: Mapping[str, Any]) -> ThrowShape:
        """The shape in `d`, a JSON object (its values are checked here)."""
        try:
            return cls(
                tuple(d["moving_joints"]),
                tuple((str(n), float(v)) for n, v in d["held_joints"]),
                float(d["acceleration_time"]),
                float(d["knot_interval"]),
                float(d["velocity_margin"]),
            )
        except (KeyError, TypeError, ValueError) as exc:
            raise LibraryFormatError(f"bad throw shape {d!r}: {exc}") from None
