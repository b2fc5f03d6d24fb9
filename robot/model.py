"""`ArmModel`: one arm's kinematics through Pinocchio, with named frames and joint limits.

Owns forward kinematics (frame placements and positions, also batched), the transform of points
between `base` and any frame (`to_frame`, `from_frame`: the project's one base <-> link1 transform),
frame Jacobians and velocities, the points used for floor checks, and the joint-limit helpers. Everything is in SI
units; every position and transform is expressed in the `base` frame (the arm's root, z up), which
is Pinocchio's world frame. Build one with `robot.load_arm`, which also defines the named frames
`base`, `link1`, `flange`, `marker` and `ball`.

Thread-safety: each ArmModel owns one `pinocchio.Data` (Pinocchio's scratch space); every method
that uses it holds the model's lock, so one ArmModel may be shared between threads (calls are
serialized, not parallel). For parallel work, load one ArmModel per thread.
"""

from __future__ import annotations

import threading
from pathlib import Path

import numpy as np
import pinocchio as pin
from numpy.typing import ArrayLike, NDArray

from wiithrow.robot.errors import RobotError
from wiithrow.robot.limits import JointLimits
from wiithrow.robot.spec import ArmSpec

#: The frames every ArmModel defines (see `wiithrow.robot.arms` for how each arm defines them).
NAMED_FRAMES = ("base", "link1", "flange", "marker", "ball")


def _points(points: ArrayLike) -> NDArray[np.float64]:
    """`points` as a float array (..., 3), or a RobotError."""
    a = np.asarray(points, dtype=float)
    if a.ndim == 0 or a.shape[-1] != 3:
        raise RobotError(f"points must have shape (3,) or (..., 3), got {a.shape}")
    return a


class ArmModel:
    """Kinematics of one serial arm with revolute joints; q is the arm's joint vector (rad).

    Attributes (read-only numpy arrays of length `nq` where applicable):
    `name`, `model` (the `pinocchio.Model`), `nq`, `joint_names`, `lower`, `upper` (rad),
    `velocity_limit` (rad/s), `acceleration_limit` (rad/s^2), `jerk_limit` (rad/s^3), `home` (rad),
    `urdf_path` (the URDF the model was built from; it may lack the `marker`/`ball` frames and,
    for arms with grippers, have more joints than `nq`), `frame_offsets` (m, along the flange z axis),
    `spec` (the `ArmSpec` it was loaded from: its throwing joints and training area; None for a
    model built by hand).
    """

    def __init__(
        self,
        name: str,
        model: pin.Model,
        limits: JointLimits,
        home: ArrayLike,
        *,
        urdf_path: Path | None = None,
        frame_offsets: dict[str, float] | None = None,
        spec: ArmSpec | None = None,
    ) -> None:
        if model.nq != model.nv:
            raise RobotError(
                f"arm '{name}': only revolute/prismatic joints are supported (nq={model.nq}, nv={model.nv})"
            )
        if limits.n != model.nq:
            raise RobotError(f"arm '{name}': {limits.n} joint limits for {model.nq} joints")
        missing = [f for f in NAMED_FRAMES if not model.existFrame(f)]
        if missing:
            raise RobotError(f"arm '{name}': the model lacks the frames {missing}")
        self.name = name
        self.model = model
        self.nq = int(model.nq)
        self.joint_names: tuple[str, ...] = tuple(limits.names)
        self._limits = limits
        self.lower = limits.lower
        self.upper = limits.upper
        self.velocity_limit = limits.velocity
        self.acceleration_limit = limits.acceleration
        self.jerk_limit = limits.jerk
        self.home = limits.check_position(home, what=f"home of arm '{name}'")
        self.home.flags.writeable = False
        self.urdf_path = urdf_path
        self.frame_offsets = dict(frame_offsets or {})
        self.spec = spec
        self._data = model.createData()
        self._lock = threading.RLock()
        self._frame_ids: dict[str, int] = {}
        self._collision_joints = self._moving_joint_origins()

    def __repr__(self) -> str:
        return f"ArmModel({self.name!r}, nq={self.nq}, joints={list(self.joint_names)})"

    # ----- limits -------------------------------------------------------------------------------

    @property
    def limits(self) -> JointLimits:
        """The joint limits as one object (for trajectory planning and the simulated arm)."""
        return self._limits

    def within_limits(self, q: ArrayLike, tol: float = 1e-9) -> bool:
        """True if `q` (nq,) is inside the position limits (with `tol` rad of slack)."""
        return self._limits.within(q, tol)

    def clip(self, q: ArrayLike) -> NDArray[np.float64]:
        """`q` (nq,) clamped into the position limits."""
        return self._limits.clip(q)

    # ----- frames -------------------------------------------------------------------------------

    @property
    def frame_names(self) -> tuple[str, ...]:
        """Every frame of the Pinocchio model (URDF links and joints, plus the named frames)."""
        return tuple(f.name for f in self.model.frames)

    def frame_id(self, frame: str) -> int:
        """Pinocchio's index of the frame called `frame`, or a RobotError listing the named frames."""
        fid = self._frame_ids.get(frame)
        if fid is None:
            if not self.model.existFrame(frame):
                raise RobotError(
                    f"arm '{self.name}' has no frame {frame!r}; the named frames are {', '.join(NAMED_FRAMES)} "
                    f"(all frames: ArmModel.frame_names)"
                )
            fid = int(self.model.getFrameId(frame))
            self._frame_ids[frame] = fid
        return fid

    def _q(self, q: ArrayLike) -> NDArray[np.float64]:
        return self._limits.vector(q)

    def frame_placement(self, q: ArrayLike, frame: str) -> NDArray[np.float64]:
        """4x4 homogeneous transform of `frame` in `base` at configuration `q`: p_base = T @ [p_frame, 1]."""
        fid = self.frame_id(frame)
        qv = self._q(q)
        with self._lock:
            pin.forwardKinematics(self.model, self._data, qv)
            return np.array(pin.updateFramePlacement(self.model, self._data, fid).homogeneous, dtype=np.float64)

    def frame_position(self, q: ArrayLike, frame: str) -> NDArray[np.float64]:
        """(3,) position of `frame`'s origin in `base` at configuration `q`."""
        return self.frame_placement(q, frame)[:3, 3].copy()

    def to_frame(self, points: ArrayLike, q: ArrayLike, frame: str = "link1") -> NDArray[np.float64]:
        """Points (..., 3) given in `base` expressed in `frame` at configuration `q` (nq,):

            p_frame = R^T (p_base - o),      (R, o) = placement of `frame` in `base` at q

        (for `link1`: p_link1 = R_1^T (p_base - o_1)). The shape is kept; NaN rows stay NaN. This is
        the one implementation of the base -> link1 transform (the rig's and the throw plane's frame).
        """
        T = self.frame_placement(q, frame)
        return (_points(points) - T[:3, 3]) @ T[:3, :3]  # row-vector form of R^T (p - o)

    def from_frame(self, points: ArrayLike, q: ArrayLike, frame: str = "link1") -> NDArray[np.float64]:
        """Points (..., 3) given in `frame` expressed in `base` at configuration `q` (nq,):

            p_base = R p_frame + o,      (R, o) = placement of `frame` in `base` at q

        the inverse of `to_frame`. The shape is kept.
        """
        T = self.frame_placement(q, frame)
        return _points(points) @ T[:3, :3].T + T[:3, 3]

    def frame_positions(self, Q: ArrayLike, frame: str) -> NDArray[np.float64]:
        """(T, 3) positions of `frame` in `base` for a batch of configurations `Q` (T, nq)."""
        fid = self.frame_id(frame)
        Qa = np.asarray(Q, dtype=float)
        if Qa.ndim != 2 or Qa.shape[1] != self.nq:
            raise RobotError(f"Q must have shape (T, {self.nq}), got {Qa.shape}")
        if not np.all(np.isfinite(Qa)):
            raise RobotError("Q must be finite")
        out = np.empty((Qa.shape[0], 3))
        with self._lock:
            for k, qk in enumerate(Qa):
                pin.forwardKinematics(self.model, self._data, qk)
                out[k] = pin.updateFramePlacement(self.model, self._data, fid).translation
        return out

    def frame_jacobian(self, q: ArrayLike, frame: str) -> NDArray[np.float64]:
        """(6, nq) Jacobian of `frame` in LOCAL_WORLD_ALIGNED: [v; w] = J @ dq.

        Rows 0-2: linear velocity of the frame's origin in `base` axes; rows 3-5: angular velocity
        in `base` axes.
        """
        fid = self.frame_id(frame)
        qv = self._q(q)
        with self._lock:
            J = pin.computeFrameJacobian(self.model, self._data, qv, fid, pin.LOCAL_WORLD_ALIGNED)
            return np.array(J, dtype=np.float64)

    def frame_placement_and_jacobian(self, q: ArrayLike, frame: str) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Both `frame_placement` (4x4) and `frame_jacobian` (6, nq) from one kinematics pass."""
        fid = self.frame_id(frame)
        qv = self._q(q)
        with self._lock:
            J = np.array(pin.computeFrameJacobian(self.model, self._data, qv, fid, pin.LOCAL_WORLD_ALIGNED), np.float64)
            # computeFrameJacobian has updated the joint placements; refresh the frame's from them
            T = np.array(pin.updateFramePlacement(self.model, self._data, fid).homogeneous, dtype=np.float64)
        return T, J

    def frame_velocity(self, q: ArrayLike, dq: ArrayLike, frame: str) -> NDArray[np.float64]:
        """(3,) linear velocity (m/s) of `frame`'s origin in `base`: v = J_lin(q) @ dq."""
        dqv = self._limits.vector(dq, "dq")
        return self.frame_jacobian(q, frame)[:3] @ dqv

    # ----- collision points ---------------------------------------------------------------------

    def _moving_joint_origins(self) -> list[int]:
        """Joints whose origin can move in `base` and does not always coincide with its parent's.

        Joint 1's origin is fixed in `base`; a joint placed at zero translation from its parent joint
        (e.g. the PA-10's S3 on S2) always shares its parent's origin, so it adds no point.
        """
        m = self.model
        keep = []
        for j in range(2, m.njoints):
            if m.parents[j] > 0 and np.linalg.norm(m.jointPlacements[j].translation) < 1e-12:
                continue
            keep.append(j)
        return keep

    @property
    def collision_point_names(self) -> tuple[str, ...]:
        """Names of the rows of `collision_points`: joint names, then flange, marker, ball."""
        return tuple(self.model.names[j] for j in self._collision_joints) + ("flange", "marker", "ball")

    def collision_points(self, q: ArrayLike) -> NDArray[np.float64]:
        """(K, 3) points in `base` on the arm's kinematic skeleton, for floor checks (z >= 0).

        The joint origins that move (see `collision_point_names`), then the flange, marker and ball
        frames. The points are on the links' axes: keep a margin of about a link radius
        (0.05-0.1 m) when checking clearance; the floor is convex-safe, since a straight segment is
        above a plane if both its ends are.
        """
        qv = self._q(q)
        fids = [self.frame_id(f) for f in ("flange", "marker", "ball")]
        with self._lock:
            pin.forwardKinematics(self.model, self._data, qv)
            pts = [self._data.oMi[j].translation.copy() for j in self._collision_joints]
            pts += [pin.updateFramePlacement(self.model, self._data, f).translation.copy() for f in fids]
        return np.array(pts)
