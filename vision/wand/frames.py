"""The frame a wand calibration is given in: the first camera, an L-frame, or the robot's link1.

A wand calibration comes out in the first camera's frame ("cam0": x to the right of its image,
y down, z along its optical axis, metres). Two others can replace it, each from 3D points the
calibrated rig measures (`old`, in the current frame) and where those points are in the new frame
(`new`):

* `lframe`: three LEDs of an L-frame seen for a second: the corner is the origin, the longer arm
  the x axis, the shorter the y axis (z = x × y). Their nominal positions are (0, 0, 0),
  (l_x, 0, 0), (0, l_y, 0), with the arm lengths given or, if not, measured;
* `robot`: the hand LED at six or more arm poses, its positions in `link1` by forward
  kinematics (as the robot calibration takes them); the result is in `link1`, so it tracks for
  the arm like a robot calibration does.

Both fit the rigid motion X_new = R X_old + t that best maps old onto new (Kabsch / Umeyama: with
centroids mu_o, mu_n and H = sum (o_i - mu_o)(n_i - mu_n)^T = U S V^T,
R = V diag(1, 1, det(V U^T)) U^T, t = mu_n - R mu_o), and report how well the frame is determined:
each point's residual ||R o_i + t - n_i||, their RMS, and the similarity scale
s = sum_i ||n_i - mu_n||^2 / sum_i (n_i - mu_n) . R (o_i - mu_o) that the points imply: a second,
independent measure of metres, which must agree with the wand's (`scale.check_scale`).

A calibration P (3x4) moves to the new frame as P' = P [[R^T, -R^T t], [0, 1]] (a point's pixels
are unchanged: P' X~_new = P X~_old).
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
from numpy.typing import ArrayLike, NDArray

from wiithrow.vision.errors import CalibrationError
from wiithrow.vision.stereo_calibration import StereoCalibration

#: Arm poses the robot frame needs at least (as the issue asks: six).
MIN_ROBOT_POSES = 6
#: An L-frame's arms must differ by this much to tell the x arm (the longer) from the y arm.
MIN_ARM_RATIO = 1.2


@dataclass(frozen=True)
class FrameFit:
    """The rigid motion to frame `name` (X_new = R X_old + t) and how well it is determined:
    residuals_m (M,) per point, `scale` the similarity scale the points imply (1 for a right wand
    length)."""

    name: str
    R: NDArray[np.float64]
    t: NDArray[np.float64]
    residuals_m: NDArray[np.float64]
    scale: float

    @property
    def rms_m(self) -> float:
        """RMS of the residuals (m); NaN for a frame placed without points (nothing to fit)."""
        return float(np.sqrt(np.mean(self.residuals_m**2))) if len(self.residuals_m) else float("nan")


def fit_rigid(old: ArrayLike, new: ArrayLike, name: str) -> FrameFit:
    """The rigid motion that maps points `old` (M, 3) onto `new` (M, 3) best (see the module docstring)."""
    o = np.asarray(old, dtype=float).reshape(-1, 3)
    n = np.asarray(new, dtype=float).reshape(-1, 3)
    if o.shape != n.shape or len(o) < 3 or not (np.isfinite(o).all() and np.isfinite(n).all()):
        raise CalibrationError(f"a frame needs 3 or more finite point pairs, got {len(o)} and {len(n)}")
    mo, mn = o.mean(axis=0), n.mean(axis=0)
    U, _, Vt = np.linalg.svd((o - mo).T @ (n - mn))
    d = np.sign(np.linalg.det(Vt.T @ U.T))
    R = Vt.T @ np.diag([1.0, 1.0, d]) @ U.T
    t = mn - R @ mo
    scale = float(((n - mn) ** 2).sum() / ((n - mn) * ((o - mo) @ R.T)).sum())
    return FrameFit(name, R, t, np.linalg.norm(o @ R.T + t - n, axis=1), scale)


def lframe_fit(points: ArrayLike, arm_lengths_m: tuple[float, float] | None = None) -> FrameFit:
    """The L-frame's frame from its three LEDs (3, 3), in any order, measured in the current frame
    (see the module docstring). CalibrationError when no corner or no longer arm can be told."""
    X = np.asarray(points, dtype=float).reshape(-1, 3)
    if X.shape != (3, 3) or not np.isfinite(X).all():
        raise CalibrationError(f"an L-frame has 3 LEDs; {len(X)} were measured")
    cosines = []
    for i in range(3):
        a, b = (X[j] - X[i] for j in range(3) if j != i)
        cosines.append(abs(a @ b) / (np.linalg.norm(a) * np.linalg.norm(b)))
    corner = int(np.argmin(cosines))
    arms = sorted((j for j in range(3) if j != corner), key=lambda j: -np.linalg.norm(X[j] - X[corner]))
    lx, ly = (float(np.linalg.norm(X[j] - X[corner])) for j in arms)
    if lx < MIN_ARM_RATIO * ly and arm_lengths_m is None:
        raise CalibrationError(
            f"the L-frame's arms measure {lx:.3f} m and {ly:.3f} m: make the x arm at least "
            f"{MIN_ARM_RATIO:g} times the y arm so they can be told apart"
        )
    nominal_x, nominal_y = arm_lengths_m if arm_lengths_m is not None else (lx, ly)
    nominal = np.array([[0.0, 0.0, 0.0], [nominal_x, 0.0, 0.0], [0.0, nominal_y, 0.0]])
    return fit_rigid(X[[corner, *arms]], nominal, "lframe")


def robot_fit(points: ArrayLike, positions_link1: ArrayLike) -> FrameFit:
    """The frame link1 from the hand LED measured at M >= 6 poses (M, 3) and its positions there by
    forward kinematics (M, 3)."""
    X = np.asarray(points, dtype=float).reshape(-1, 3)
    if len(X) < MIN_ROBOT_POSES:
        raise CalibrationError(f"the robot frame needs the hand LED at {MIN_ROBOT_POSES} or more poses, got {len(X)}")
    return fit_rigid(X, positions_link1, "link1")


def transform_calibration(calibration: StereoCalibration, fit: FrameFit) -> StereoCalibration:
    """The calibration in frame `fit.name` (see the module docstring for P')."""
    T_inv = np.eye(4)
    T_inv[:3, :3] = fit.R.T
    T_inv[:3, 3] = -fit.R.T @ fit.t
    cameras = tuple(
        replace(c, P=c.P @ T_inv, world=c.world @ fit.R.T + fit.t if len(c.world) else c.world)
        for c in calibration.cameras
    )
    fitted = len(fit.residuals_m) > 0
    meta = {
        **calibration.meta,
        "frame_fit": {
            "from": calibration.frame,
            "to": fit.name,
            "rms_m": fit.rms_m if fitted else None,
            "max_m": float(fit.residuals_m.max()) if fitted else None,
            "points": len(fit.residuals_m),
            "scale": fit.scale,
        },
    }
    return StereoCalibration(cameras, fit.name, calibration.loo_error_m, meta)
