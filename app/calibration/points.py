"""Calibrating a rig from a set of known 3D points and their pixels in every camera.

Shared by `wiithrow calibrate --points FILE.csv`, the robot-driven calibration and the dashboard:
fit each camera on the points it saw, cross-validate (leave-one-out 3D error), keep the result as
a `StereoCalibration` in the points' frame.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

from wiithrow.vision import StereoCalibration, calibrate, leave_one_out
from wiithrow.vision.crossval import LeaveOneOut
from wiithrow.vision.dlt import Method
from wiithrow.vision.errors import CalibrationError


class RigCalibration(NamedTuple):
    calibration: StereoCalibration
    loo: LeaveOneOut


def calibrate_rig(
    points: NDArray[np.float64],
    image: NDArray[np.float64],
    *,
    method: Method = "refined",
    frame: str = "link1",
    cross_validate: bool = True,
    meta: dict | None = None,
) -> RigCalibration:
    """Fit every camera of (C, N, 2) `image` to the known 3D `points` (N, 3) and cross-validate the rig."""
    if image.ndim != 3 or image.shape[0] < 2 or image.shape[1] != points.shape[0]:
        raise CalibrationError(
            f"need pixels (C >= 2, N, 2) for known points (N, 3); got {image.shape} for {points.shape}"
        )
    cameras = []
    for c in range(image.shape[0]):
        seen = np.isfinite(image[c]).all(axis=1)
        try:
            cameras.append(calibrate(points[seen], image[c, seen], method, name=f"cam{c}"))
        except CalibrationError as exc:
            raise CalibrationError(f"camera {c} ({seen.sum()} points seen): {exc}") from None
    loo = leave_one_out(points, image, method, cameras=cameras) if cross_validate else LeaveOneOut(np.full(len(points), np.nan))
    calibration = StereoCalibration(tuple(cameras), frame, loo.mean if cross_validate else None, dict(meta or {}))
    return RigCalibration(calibration, loo)
