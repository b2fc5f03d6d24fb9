"""Measuring a pose design without the robot: ideal positions, simulated pixels averaged over
frames as the calibration does; the leave-one-out error and the ratio of the calibrated rig's test
error to the true cameras' on the same noisy test pixels (`evaluate_design`, `score_calibration`).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from wiithrow.vision import calibrate, leave_one_out, triangulate
from wiithrow.vision.camera import WiimoteCamera
from wiithrow.vision.dlt import Method


@dataclass(frozen=True)
class DesignScore:
    """A design's measured quality: leave-one-out mean 3D error (m), the calibrated rig's mean test
    error (m), the true cameras' on the same pixels (m) (their ratio), and the calibration's own
    share: the mean distance between the points the calibrated and the true cameras triangulate
    from the same pixels (m; free of the test pixels' noise, so it separates designs best)."""

    loo_m: float
    test_m: float
    true_test_m: float
    calibration_m: float

    @property
    def ratio(self) -> float:
        return self.test_m / self.true_test_m


def averaged_pixels(
    cameras: Sequence[WiimoteCamera],
    points: ArrayLike,
    rng: np.random.Generator,
    *,
    sigma_px: float = 0.5,
    frames: int = 10,
) -> NDArray[np.float64]:
    """Pixels (C, N, 2) of still points averaged over `frames` noisy, rounded frames (NaN if unseen)."""
    X = np.asarray(points, dtype=float).reshape(-1, 3)
    stack = np.stack([[c.observe(X, rng, sigma_px=sigma_px, max_blobs=None) for c in cameras] for _ in range(frames)])
    return stack.mean(axis=0)


def evaluate_design(
    cameras: Sequence[WiimoteCamera],
    positions: ArrayLike,
    test_points: ArrayLike,
    rng: np.random.Generator,
    *,
    sigma_px: float = 0.5,
    frames: int = 10,
    method: Method = "refined",
    cross_validate: bool = True,
) -> DesignScore:
    """Calibrate ideal cameras on `positions` (pixels averaged over `frames` frames, as the robot
    calibration takes them) and measure it: leave-one-out error, and mean 3D error on one noisy
    frame of each test point against the true cameras' on the same pixels."""
    X = np.asarray(positions, dtype=float)
    image = averaged_pixels(cameras, X, rng, sigma_px=sigma_px, frames=frames)
    Ps = np.stack([calibrate(X, image[c], method).P for c in range(len(cameras))])
    loo = leave_one_out(X, image, method).mean if cross_validate else float("nan")
    return score_calibration(Ps, cameras, test_points, rng, sigma_px=sigma_px, loo_m=loo)


def score_calibration(
    Ps: ArrayLike,
    cameras: Sequence[WiimoteCamera],
    test_points: ArrayLike,
    rng: np.random.Generator,
    *,
    sigma_px: float = 0.5,
    loo_m: float = float("nan"),
) -> DesignScore:
    """Test calibrated projection matrices (C, 3, 4) against the true `cameras`: one noisy, rounded
    frame of each test point (N, 3), triangulated by both (see DesignScore)."""
    T = np.asarray(test_points, dtype=float).reshape(-1, 3)
    test_image = np.stack([c.observe(T, rng, sigma_px=sigma_px, max_blobs=None) for c in cameras])
    calibrated = triangulate(np.asarray(Ps, dtype=float), test_image).points
    true = triangulate(np.stack([c.P for c in cameras]), test_image).points
    err = np.linalg.norm(calibrated - T, axis=1)
    true_err = np.linalg.norm(true - T, axis=1)
    return DesignScore(
        float(loo_m),
        float(np.nanmean(err)),
        float(np.nanmean(true_err)),
        float(np.nanmean(np.linalg.norm(calibrated - true, axis=1))),
    )
