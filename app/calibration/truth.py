"""A calibration against a simulated world's truth: its 3D error over the throwing area, relative to
the true cameras' on the same pixels.

    points X_n: a seeded uniform sample of the area (x = distance from the joint-1 axis, z = height,
        y = 0: the throw plane, where the rig measures targets and landings) in link1;
    the true pixels: X_n to base by the nominal model at the arm's joints now (link1 as the system
        knows it: what a target aligned in the throw plane is), then into the TRUE link1, where the
        remotes are mounted (the MuJoCo world's link1 stands at q1 + its zero offset; the kinematic
        world's is the nominal one), seen by the mounted cameras with the world's pixel noise and
        rounding (`WiimoteCamera.observe`, one frame);
    e_true = || triangulate(true P, pixels) - X_true_link1 ||,  e_cal = || triangulate(calibrated P, pixels) - X_n ||;
    ratio = median(e_cal) / median(e_true).

The calibrated cameras are compared in nominal link1 because that is where the system uses their
measurements (to turn joint 1 and to place the throw plane). The ratio is the issue's figure of
merit (goal <= 1.5 in MuJoCo): 1 is a calibration as good as knowing the cameras.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from wiithrow.app.worlds import RigWorld
from wiithrow.app.worlds.mujoco.world import MujocoWorld
from wiithrow.throwing import TRAINING_AREA
from wiithrow.vision import StereoCalibration, triangulate


@dataclass(frozen=True)
class AreaError:
    """Median 3D errors (m) over the test points of the calibrated and the true cameras on the
    same pixels, their ratio, and how many points both triangulated."""

    calibrated_m: float
    true_m: float
    points: int

    @property
    def ratio(self) -> float:
        return self.calibrated_m / self.true_m

    def to_dict(self) -> dict[str, float | int]:
        return {
            "calibrated_median_m": self.calibrated_m,
            "true_cameras_median_m": self.true_m,
            "ratio": self.ratio,
            "points": self.points,
        }


def area_points(
    rng: np.random.Generator,
    n: int = 5000,
    x_range: tuple[float, float] = TRAINING_AREA.x,
    z_range: tuple[float, float] = TRAINING_AREA.z,
) -> NDArray[np.float64]:
    """`n` points (n, 3) in link1, uniform over the area's (x, z) in the throw plane (y = 0)."""
    return np.column_stack([rng.uniform(*x_range, n), np.zeros(n), rng.uniform(*z_range, n)])


def true_link1(world: RigWorld) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """(R, o) of the link1 the rig is really mounted on, in base, now."""
    if isinstance(world, MujocoWorld):
        return world.lab.link1_pose()
    T = world.arm_model.frame_placement(world.arm.state().q, "link1")
    return T[:3, :3], T[:3, 3]


def area_error(
    world: RigWorld,
    calibration: StereoCalibration,
    rng: np.random.Generator,
    points: ArrayLike | None = None,
) -> AreaError:
    """The calibration's 3D error over `points` (link1, default `area_points`) against the true
    cameras' on the same pixels (module docstring)."""
    X = area_points(rng) if points is None else np.asarray(points, dtype=float).reshape(-1, 3)
    q = world.arm.state().q
    base = world.arm_model.from_frame(X, q, "link1")
    R, o = true_link1(world)
    X_true = (base - o) @ R
    sigma = world.settings.noise.pixel_sigma_px
    pixels = np.stack([c.observe(X_true, rng, sigma_px=sigma, max_blobs=None) for c in world.cameras])
    e_true = np.linalg.norm(triangulate(world.true_calibration_Ps(), pixels).points - X_true, axis=1)
    e_cal = np.linalg.norm(triangulate(calibration.Ps, pixels).points - X, axis=1)
    both = np.isfinite(e_true) & np.isfinite(e_cal)
    return AreaError(float(np.median(e_cal[both])), float(np.median(e_true[both])), int(both.sum()))
