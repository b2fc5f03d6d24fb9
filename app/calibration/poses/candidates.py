"""Candidate poses of the calibration LED: reachable, seen by every camera, facing the rig.

`sample_candidates` draws configurations of the arm with joint 1 at 0 (so `link1` is `base`),
uniformly in the joint limits and then by a random walk from the accepted ones, and keeps those
whose marker (the LED) is
- in the common field of view of the NOMINAL cameras, `margin_px` inside every image (on
  hardware the true cameras are unknown; a pose they do not see is replaced at run time),
- at x (distance from the joint-1 axis) in `x_range`,
- facing the cameras: the angle between the marker frame's z axis (the LED's axis) and the
  direction to the rig's centre at most `max_led_angle_deg`,
- with the arm's skeleton `floor_clearance_m` above the floor and `rig_clearance_m` away from
  every camera (`PoseCheck`).
Every candidate is reachable by construction (its configuration is known), so the arm's real
reach, not an assumed box, bounds the volume. The cloud is thinned to one candidate per voxel
(the best-facing one), which makes it about uniform in space.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from wiithrow.app.errors import AppError
from wiithrow.robot import ArmModel
from wiithrow.vision.camera import WiimoteCamera
from wiithrow.vision.rig import point_in_common_view


@dataclass(frozen=True)
class PoseCandidates:
    """Reachable marker positions the cameras see: `positions` (M, 3) in link1, the configurations
    `q` (M, nq) with joint 1 at 0 that put the marker there, and the LED's angle to the rig
    `led_angle_rad` (M,)."""

    positions: NDArray[np.float64]
    q: NDArray[np.float64]
    led_angle_rad: NDArray[np.float64]
    voxel_m: float

    def __len__(self) -> int:
        return int(self.positions.shape[0])

    @property
    def volume_m3(self) -> float:
        """The volume the candidates fill (occupied voxels)."""
        return len(self) * self.voxel_m**3

    def subset(self, index: ArrayLike) -> PoseCandidates:
        i = np.asarray(index, dtype=np.int64)
        return PoseCandidates(self.positions[i], self.q[i], self.led_angle_rad[i], self.voxel_m)


def rig_center(cameras: Sequence[WiimoteCamera]) -> NDArray[np.float64]:
    """Mean of the cameras' optical centres (in their frame)."""
    return np.mean([c.center for c in cameras], axis=0)


def _segment_distance(
    points: NDArray[np.float64], a: NDArray[np.float64], b: NDArray[np.float64]
) -> NDArray[np.float64]:
    """Distance (P, S) from each point (P, 3) to each segment a[s] -> b[s] (S, 3)."""
    d = b - a
    L2 = np.maximum((d * d).sum(axis=1), 1e-18)
    s = np.clip(((points[:, None, :] - a[None]) * d[None]).sum(axis=2) / L2, 0.0, 1.0)
    closest = a[None] + s[..., None] * d[None]
    return np.linalg.norm(points[:, None, :] - closest, axis=2)


class PoseCheck:
    """Accept or reject one configuration as a calibration pose (joint 1 is ignored: everything is
    checked in link1, which turns with it)."""

    def __init__(
        self,
        arm: ArmModel,
        cameras: Sequence[WiimoteCamera],
        x_range: tuple[float, float] = (0.0, np.inf),
        margin_px: float = 20.0,
        max_led_angle_deg: float = 60.0,
        floor_clearance_m: float = 0.05,
        rig_clearance_m: float = 0.10,
    ) -> None:
        self.arm, self.cameras = arm, list(cameras)
        self.x_range, self.margin_px = x_range, margin_px
        self.cos_led = np.cos(np.deg2rad(max_led_angle_deg))
        self.floor, self.clearance = floor_clearance_m, rig_clearance_m
        self.centers = np.array([c.center for c in self.cameras])
        self.rig = rig_center(self.cameras)
        q0 = arm.home.copy()
        q0[0] = 0.0
        T = arm.frame_placement(q0, "link1")  # link1 depends on q1 only: constant at q1 = 0
        self.R1, self.o1 = T[:3, :3], T[:3, 3]

    def __call__(self, q: NDArray[np.float64]) -> tuple[NDArray[np.float64], float] | None:
        """(position in link1, LED angle) if q is acceptable, else None."""
        q = np.array(q, dtype=float)
        q[0] = 0.0
        T = self.arm.frame_placement(q, "marker")
        p = (T[:3, 3] - self.o1) @ self.R1
        if not self.x_range[0] <= p[0] <= self.x_range[1]:
            return None
        if not point_in_common_view(self.cameras, p, self.margin_px):
            return None
        to_rig = self.rig - p
        cos = float((T[:3, 2] @ self.R1) @ to_rig / np.linalg.norm(to_rig))
        if cos < self.cos_led:
            return None
        skeleton = (self.arm.collision_points(q) - self.o1) @ self.R1
        if skeleton[:, 2].min() < self.floor:
            return None
        chain = np.vstack([np.zeros((1, 3)), skeleton])
        if _segment_distance(self.centers, chain[:-1], chain[1:]).min() < self.clearance:
            return None
        return p, float(np.arccos(np.clip(cos, -1.0, 1.0)))


def sample_candidates(
    arm: ArmModel,
    cameras: Sequence[WiimoteCamera],
    rng: np.random.Generator,
    *,
    x_range: tuple[float, float] = (0.45, 1.0),
    margin_px: float = 20.0,
    max_led_angle_deg: float = 60.0,
    floor_clearance_m: float = 0.05,
    rig_clearance_m: float = 0.10,
    voxel_m: float = 0.03,
    n_uniform: int = 3000,
    n_walk: int = 5000,
    walk_sigma_rad: float = 0.25,
) -> PoseCandidates:
    """Reachable, visible, LED-facing marker positions (see the module docstring), one per voxel.

    Raises AppError when no configuration of the arm puts the marker where the cameras see it.
    """
    check = PoseCheck(arm, cameras, x_range, margin_px, max_led_angle_deg, floor_clearance_m, rig_clearance_m)
    lo, hi = arm.lower.copy(), arm.upper.copy()
    lo[0] = hi[0] = 0.0
    qs, ps, angles = [], [], []

    def consider(q: NDArray[np.float64]) -> None:
        got = check(q)
        if got is not None:
            qs.append(q)
            ps.append(got[0])
            angles.append(got[1])

    # the home posture is usually in front of the arm: try it first
    consider(arm.clip(np.where(np.arange(arm.nq) == 0, 0.0, arm.home)))
    drawn = 0
    while drawn < n_uniform or (len(qs) < 3 and drawn < 5 * n_uniform):  # arms with wide limits need more
        for q in rng.uniform(lo, hi, (min(n_uniform, 1000), arm.nq)):
            consider(q)
        drawn += min(n_uniform, 1000)
    if not qs:
        raise AppError(
            f"arm '{arm.name}': none of {drawn} random configurations puts the marker where every camera "
            f"sees it at x {x_range[0]:.2f}-{x_range[1]:.2f} m with the LED facing the rig: move the rig "
            "(settings rig.center, rig.pitch_down_deg) in front of the arm's reach"
        )
    step = np.where(np.arange(arm.nq) == 0, 0.0, walk_sigma_rad)
    for _ in range(n_walk):
        q = qs[int(rng.integers(len(qs)))] + rng.normal(0.0, 1.0, arm.nq) * step
        consider(np.clip(q, lo, hi))
    P, Q, A = np.array(ps), np.array(qs), np.array(angles)
    # one candidate per voxel: the one whose LED faces the rig best
    keys = np.floor(P / voxel_m).astype(np.int64)
    order = np.lexsort((A, keys[:, 2], keys[:, 1], keys[:, 0]))
    k = keys[order]
    first = np.ones(len(order), dtype=bool)
    first[1:] = np.any(k[1:] != k[:-1], axis=1)
    keep = order[first]
    return PoseCandidates(P[keep], Q[keep], A[keep], voxel_m)
