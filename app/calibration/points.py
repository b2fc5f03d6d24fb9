"""Calibrating a rig from a set of known 3D points and their pixels in every camera.

Shared by `wiithrow calibrate --points FILE.csv`, the robot-driven calibration and the dashboard:
fit each camera on the points it saw, cross-validate (leave-one-out 3D error), keep the result as
a `StereoCalibration` in the points' frame.

Points are numbered from 1 in what this module says (point 1 is the first row of a points file,
or the first pose measured), whatever camera saw them.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

from wiithrow.app.progress import progress_bar
from wiithrow.vision import StereoCalibration, calibrate, leave_one_out
from wiithrow.vision.crossval import LeaveOneOut
from wiithrow.vision.dlt import CalibratedCamera, Method, duplicated_points
from wiithrow.vision.errors import CalibrationError


class RigCalibration(NamedTuple):
    calibration: StereoCalibration
    loo: LeaveOneOut


def numbered(indices: NDArray[np.int64], most: int = 8) -> str:
    """Point indices as the 1-based numbers users see: '3, 17, 20, ...'."""
    shown = ", ".join(str(int(i) + 1) for i in indices[:most])
    return shown + (", ..." if len(indices) > most else "")


def calibrate_rig(
    points: NDArray[np.float64],
    image: NDArray[np.float64],
    *,
    method: Method = "refined",
    frame: str = "link1",
    cross_validate: bool = True,
    meta: dict | None = None,
    show_progress: bool = False,
) -> RigCalibration:
    """Fit every camera of (C, N, 2) `image` to the known 3D `points` (N, 3) and cross-validate the rig.

    `show_progress`: a bar over the fits and the leave-one-out on a terminal (100,000 points take
    seconds)."""
    if image.ndim != 3 or image.shape[0] < 2 or image.shape[1] != points.shape[0]:
        raise CalibrationError(
            f"need pixels (C >= 2, N, 2) for known points (N, 3); got {image.shape} for {points.shape}"
        )
    dup = duplicated_points(points)
    if dup.size:
        raise CalibrationError(
            f"points {numbered(dup)} (numbered from 1) occur more than once: each calibration point must be "
            "a distinct position; average repeated measurements instead"
        )
    cameras: list[CalibratedCamera] = []
    steps = image.shape[0] + int(cross_validate)
    with progress_bar(total=steps, show=show_progress, desc="calibration", unit="step", leave=False) as bar:
        for c in range(image.shape[0]):
            seen = np.isfinite(image[c]).all(axis=1)
            bar.set_postfix_str(f"fitting cam{c} ({seen.sum()} points)")
            try:
                cameras.append(calibrate(points[seen], image[c, seen], method, name=f"cam{c}"))
            except CalibrationError as exc:
                raise CalibrationError(f"camera {c} ({seen.sum()} points seen): {exc}") from None
            bar.update(1)
        if cross_validate:
            bar.set_postfix_str("leave-one-out")
            loo = leave_one_out(points, image, method, cameras=cameras)
            bar.update(1)
        else:
            loo = LeaveOneOut(np.full(len(points), np.nan), "not cross-validated")
    calibration = StereoCalibration(tuple(cameras), frame, loo.mean if loo.tested else None, dict(meta or {}))
    return RigCalibration(calibration, loo)
