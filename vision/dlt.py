"""Calibration of one camera by the Direct Linear Transform: P from known 3D points and their pixels.

A camera maps a point X = (x, y, z) to the pixel (u, v) by the 3x4 projection matrix P:

    u = (p11 x + p12 y + p13 z + p14) / (p31 x + p32 y + p33 z + p34)
    v = (p21 x + p22 y + p23 z + p24) / (p31 x + p32 y + p33 z + p34)                      (paper eq. 15)

Each point gives two equations linear in the entries of P. The methods:

* ``"paper"`` -- the seed paper's solve (eq. 16-18): fix p34 = 1, so the 11 remaining unknowns
  a = (p11..p33) solve A a = b with rows

      [x y z 1 0 0 0 0 -u x -u y -u z] a = u,   [0 0 0 0 x y z 1 -v x -v y -v z] a = v,

  by the pseudo-inverse a = (A^T A)^-1 A^T b. Unnormalised; breaks down when the world origin lies
  near the camera's focal plane (then p34 ~ 0 and cannot be 1).
* ``"normalized"`` -- Hartley's normalised DLT: translate the pixels to their centroid and scale
  them to RMS distance sqrt(2), the world points likewise to sqrt(3); solve the homogeneous system
  A p = 0 (12 unknowns, ||p|| = 1): p is the right singular vector of A's smallest singular
  value, the eigenvector of the smallest eigenvalue of the 12 x 12 normal matrix A^T A, which
  takes O(N) time and no memory beyond the points; undo the normalisations: P = T^-1 P_n U.
* ``"refined"`` (default) -- the normalised solution refined by Levenberg-Marquardt
  (scipy.optimize.least_squares) on the reprojection error sum_i ||x_i - pi(P, X_i)||^2: the
  maximum-likelihood fit under Gaussian pixel noise. P is parametrised minimally by its 11 degrees
  of freedom, P = K [R | -R C] with K upper-triangular (fx, skew, cx, fy, cy), R = exp([w]x) and the
  centre C.
* ``"robust"`` -- the paper's "recursive pseudo-inverse" (inaccurate points weigh less) done
  properly: a seeded RANSAC over minimal 6-point samples finds a consensus set, then the refinement
  runs with a Cauchy loss (iteratively re-weighted least squares in effect) so gross outliers lose
  their influence, and a final refit uses the inliers only.

This module owns the entry point `calibrate` (input checks, the choice of method, the checks of
the fit) and its result, `CalibratedCamera`; the solves themselves are `dlt_solvers`', the
projection and the decomposition P = K [R | t] `geometry`'s.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any, Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray

from wiithrow.vision.dlt_solvers import (
    DEGENERACY_RATIO,
    MIN_POINTS,
    canonical,
    refine,
    solve_normalized,
    solve_paper,
    solve_robust,
)
from wiithrow.vision.errors import CalibrationError
from wiithrow.vision.geometry import Decomposition, decompose, homogeneous, project, reprojection_errors

Method = Literal["paper", "normalized", "refined", "robust"]
METHODS: tuple[Method, ...] = ("paper", "normalized", "refined", "robust")

#: A fit whose RMS reprojection error exceeds this many pixels describes no camera.
DEFAULT_MAX_RMS_PX = 20.0
#: The largest magnitude of any number a calibration holds: P = K [R | t] of a Wiimote has entries
#: of order f |t| ~ 1e3-1e4 with p34 ~ 1 (a DLT file's scale); points are metres and pixels,
#: residuals pixels. 1e12 leaves eight orders of magnitude for any other scale of P, and keeps the
#: checks' arithmetic (norms, determinants: cubes of entries) far from overflowing.
MAX_CALIBRATION_NUMBER = 1e12


@dataclass(frozen=True)
class CalibratedCamera:
    """A camera fitted by `calibrate`: its projection matrix and how well it fits its data.

    `residuals_px[i]` is the reprojection error of calibration point i (pixels); `inliers` marks
    the points the fit trusts (all of them, except for the robust method).
    """

    P: NDArray[np.float64]
    method: str
    world: NDArray[np.float64] = field(repr=False)
    image: NDArray[np.float64] = field(repr=False)
    residuals_px: NDArray[np.float64] = field(repr=False)
    inliers: NDArray[np.bool_] = field(repr=False)
    image_size: tuple[int, int] = (1024, 768)
    name: str = "cam0"

    @property
    def rms_px(self) -> float:
        """RMS reprojection error of the inlier calibration points (pixels); NaN without any (a
        camera built from a known P, not fitted)."""
        r = self.residuals_px[self.inliers]
        return float(np.sqrt(np.mean(r**2))) if r.size else float("nan")

    def project(self, points: ArrayLike) -> NDArray[np.float64]:
        """Pixels (N, 2) of points (N, 3) in the calibration frame; NaN behind the camera."""
        return project(self.P, points)

    def decompose(self) -> Decomposition:
        """P = K [R | t] by RQ decomposition (see `decompose`)."""
        return decompose(self.P)

    def to_dict(self) -> dict[str, Any]:
        """A JSON-ready description: P, its decomposition, the fit's residuals and method."""
        d = self.decompose()
        return {
            "name": self.name,
            "method": self.method,
            "image_size": list(self.image_size),
            "P": self.P.tolist(),
            "K": d.K.tolist(),
            "R": d.R.tolist(),
            "t": d.t.tolist(),
            "center": d.center.tolist(),
            "mirrored": d.mirrored,
            "rms_px": self.rms_px,
            "residuals_px": self.residuals_px.tolist(),
            "inliers": self.inliers.tolist(),
            "world": self.world.tolist(),
            "image": self.image.tolist(),
        }

    @classmethod
    def from_dict(cls, data: Any) -> CalibratedCamera:
        """Inverse of `to_dict`, every field checked: CalibrationError naming the field (`K[0][2]
        is NaN`) for one that is missing, of the wrong kind or shape, or not finite (NaN, an
        infinity, null where a number belongs). Only `P` is required. The decomposition (K, R, t,
        centre) and `rms_px` are derived from P and the residuals, not read, but checked all the
        same (`rms_px` is NaN only for a camera without fitted points, as `to_dict` gives it; a
        file holds null there). A residual is null (infinite, in `to_dict`'s strict JSON) only
        for a point outside the fit (`inliers` false): one behind the camera."""
        if not isinstance(data, dict):
            raise CalibrationError(f"a camera is a JSON object, got {type(data).__name__}")
        P = _numbers(data, "P", (3, 4))
        for derived, shape in (("K", (3, 3)), ("R", (3, 3)), ("t", (3,)), ("center", (3,))):
            if derived in data:
                _numbers(data, derived, shape)
        world = _numbers(data, "world", (None, 3), empty_ok=True)
        image = _numbers(data, "image", (None, 2), empty_ok=True)
        if len(world) != len(image):
            raise CalibrationError(f"{len(world)} world points but {len(image)} image points")
        inliers_raw = data.get("inliers")
        residuals = _numbers(data, "residuals_px", (None,), empty_ok=True, null_where=inliers_raw)
        if residuals.size not in (0, len(world)) and len(world):
            raise CalibrationError(f"{residuals.size} residuals_px for {len(world)} points")
        if inliers_raw is None:
            inliers = np.ones(residuals.size, dtype=bool)
        elif isinstance(inliers_raw, list) and all(isinstance(v, bool) for v in inliers_raw):
            inliers = np.array(inliers_raw, dtype=bool).reshape(-1)
        else:
            raise CalibrationError("inliers must be a list of true and false")
        if inliers.size != residuals.size:
            raise CalibrationError(f"{inliers.size} inliers for {residuals.size} residuals_px")
        rms = data.get("rms_px")
        unfitted = not inliers.any()  # rms_px is NaN (`to_dict`), null in a file
        if rms is not None and not (_is_number(rms) and (0 <= rms < math.inf or (unfitted and math.isnan(rms)))):
            raise CalibrationError(f"rms_px must be a number >= 0 or null, got {rms!r}")
        size = data.get("image_size", [1024, 768])
        if not (isinstance(size, list) and len(size) == 2 and all(_is_int(v) and v > 0 for v in size)):
            raise CalibrationError(f"image_size must be [width, height] in whole pixels, got {size!r}")
        for key in ("method", "name"):
            if key in data and not isinstance(data[key], str):
                raise CalibrationError(f"{key} must be a string, got {data[key]!r}")
        if "mirrored" in data and not isinstance(data["mirrored"], bool):
            raise CalibrationError(f"mirrored must be true or false, got {data['mirrored']!r}")
        return cls(
            P,
            data.get("method", "unknown"),
            world,
            image,
            residuals,
            inliers,
            (int(size[0]), int(size[1])),
            data.get("name", "cam0"),
        )


def _is_number(value: Any) -> bool:
    return isinstance(value, int | float) and not isinstance(value, bool)


def _is_int(value: Any) -> bool:
    return isinstance(value, int) and not isinstance(value, bool)


def _numbers(
    data: dict[str, Any],
    key: str,
    shape: tuple[int | None, ...],
    *,
    empty_ok: bool = False,
    null_where: Any = None,
) -> NDArray[np.float64]:
    """`data[key]` as a float array of `shape` (None: any length), every entry a finite number;
    CalibrationError naming the entry otherwise. `empty_ok`: missing or [] is an empty array of
    that shape. `null_where`: the `inliers` list, where false allows null (read as inf)."""
    if key not in data or (empty_ok and isinstance(data[key], list) and not data[key]):
        if not empty_ok:
            raise CalibrationError(f"{key} is missing")
        return np.zeros(tuple(0 if n is None else n for n in shape))
    raw = data[key]
    kind = " x ".join("N" if n is None else str(n) for n in shape)
    try:
        array = np.asarray(raw, dtype=float)
    except (TypeError, ValueError):
        raise CalibrationError(f"{key} must be a {kind} array of numbers") from None
    if array.ndim != len(shape) or any(n is not None and n != m for n, m in zip(shape, array.shape)):
        raise CalibrationError(f"{key} must be a {kind} array of numbers, got shape {array.shape}")
    bad = np.argwhere(~np.isfinite(array))
    for index in bad:
        value = raw
        for i in index:
            value = value[i]
        outlier = isinstance(null_where, list) and len(null_where) == len(array) and null_where[index[0]] is False
        if value is None and outlier:
            array[tuple(index)] = np.inf
            continue
        where = key + "".join(f"[{i}]" for i in index)
        what = "null (no number)" if value is None else ("NaN" if math.isnan(value) else repr(value))
        raise CalibrationError(f"{where} is {what}: every number in a calibration must be finite")
    with np.errstate(invalid="ignore"):  # the outliers' inf residuals are allowed above
        huge = np.argwhere(np.isfinite(array) & (np.abs(array) > MAX_CALIBRATION_NUMBER))
    if len(huge):
        at = tuple(int(i) for i in huge[0])
        where = key + "".join(f"[{i}]" for i in at)
        owner = "camera's projection matrix" if key == "P" else "calibration"
        raise CalibrationError(
            f"{where} is {array[at]:g}, beyond {MAX_CALIBRATION_NUMBER:g} in magnitude: no {owner} has such an entry"
        )
    return array


# --------------------------------------------------------------------------------------------
# Input checks


def _as_points(world: ArrayLike, image: ArrayLike) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Validate calibration input; raise CalibrationError saying what is wrong and what to do."""
    try:
        X = np.asarray(world, dtype=float)
        x = np.asarray(image, dtype=float)
    except (TypeError, ValueError) as exc:
        raise CalibrationError(f"calibration points must be numeric arrays ({exc})") from None
    if X.ndim != 2 or X.shape[1] != 3:
        raise CalibrationError(f"world points must have shape (N, 3), got {X.shape}")
    if x.ndim != 2 or x.shape[1] != 2:
        raise CalibrationError(f"image points must have shape (N, 2), got {x.shape}")
    if X.shape[0] != x.shape[0]:
        raise CalibrationError(f"{X.shape[0]} world points but {x.shape[0]} image points: give one pixel per 3D point")
    bad = ~(np.isfinite(X).all(axis=1) & np.isfinite(x).all(axis=1))
    if bad.any():
        rows = np.flatnonzero(bad)
        raise CalibrationError(
            f"{bad.sum()} calibration point(s) contain NaN or inf (rows {_list(rows)}): "
            "drop the points this camera did not see before calibrating it"
        )
    if X.shape[0] < MIN_POINTS:
        raise CalibrationError(
            f"a camera needs at least {MIN_POINTS} calibration points (11 unknowns, 2 equations "
            f"per point), got {X.shape[0]}; the paper recommends 30 or more"
        )
    dup = duplicated_points(X)
    if dup.size:
        raise CalibrationError(
            f"duplicated 3D calibration points (first copies at rows {_list(dup)}): "
            "each point must be a distinct position; average repeated measurements instead"
        )
    s = np.linalg.svd(X - X.mean(axis=0), compute_uv=False)
    if s[1] <= DEGENERACY_RATIO * s[0]:
        raise CalibrationError(
            "the 3D calibration points are collinear: they cannot determine a camera; spread them through a volume"
        )
    if s[2] <= DEGENERACY_RATIO * s[0]:
        raise CalibrationError(
            "the 3D calibration points are coplanar (rank-deficient DLT): a 3x4 projection matrix "
            "needs points spread in depth as well; add points off the plane"
        )
    return X, x


def duplicated_points(X: NDArray[np.float64]) -> NDArray[np.int64]:
    """Indices of the first copy of every 3D point that occurs more than once (equal to 1e-9 of
    the points' extent), ascending."""
    if X.shape[0] < 2:
        return np.zeros(0, dtype=np.int64)
    scale = float(np.ptp(X, axis=0).max())
    if not scale > 0:  # every point is the same point
        return np.zeros(1, dtype=np.int64)
    _, first, counts = np.unique(np.round(X / (scale * 1e-9)), axis=0, return_index=True, return_counts=True)
    return np.sort(first[counts > 1]).astype(np.int64)


def _list(indices: NDArray[np.int64], most: int = 8) -> str:
    shown = ", ".join(str(int(i)) for i in indices[:most])
    return shown + (", ..." if len(indices) > most else "")


# --------------------------------------------------------------------------------------------
# The entry point


def calibrate(
    world: ArrayLike,
    image: ArrayLike,
    method: Method = "refined",
    *,
    image_size: tuple[int, int] = (1024, 768),
    name: str = "cam0",
    max_rms_px: float = DEFAULT_MAX_RMS_PX,
    rng: np.random.Generator | None = None,
) -> CalibratedCamera:
    """Fit one camera's projection matrix to N >= 6 known 3D points and their pixels.

    The returned P is scaled so that ||P[2, :3]|| = 1 with the calibration points in front of the
    camera (then (P X~)_3 is their depth in the world's unit).

    Args:
        world: (N, 3) known points, in the frame the calibration is to be in (m).
        image: (N, 2) their pixels (u right, v down, px).
        method: "paper", "normalized", "refined" (the default) or "robust" (module docstring).
        image_size: the image's (width, height) in px.
        name: the camera's name in the calibration file.
        max_rms_px: the largest RMS reprojection error (px) a fit may have.
        rng: seeds the robust method's sampling (default: a fixed seed, so results are reproducible).

    Returns:
        The fitted camera: its P (3, 4), its residuals (px) per point and which points it trusts.

    Raises:
        CalibrationError: fewer than 6 points, mismatched shapes, NaN/inf, duplicated points,
            collinear or coplanar points, a fit whose RMS reprojection error exceeds `max_rms_px`
            or that puts calibration points behind the camera (the data do not describe one camera).
    """
    X, x = _as_points(world, image)
    if method not in METHODS:
        raise CalibrationError(f"unknown calibration method {method!r}; choose one of {', '.join(METHODS)}")
    inliers = np.ones(X.shape[0], dtype=bool)
    if method == "paper":
        P = solve_paper(X, x)
    elif method == "normalized":
        P = solve_normalized(X, x)
    elif method == "refined":
        P = refine(solve_normalized(X, x), X, x)
    else:
        P, inliers = solve_robust(X, x, rng if rng is not None else np.random.default_rng(0))
    if not np.all(np.isfinite(P)) or np.linalg.norm(P[2, :3]) == 0:
        raise CalibrationError(
            f"the {method!r} solve gave no finite camera"
            + (
                ": the world origin is probably near the camera's focal plane; use 'normalized'"
                if method == "paper"
                else ""
            )
        )
    P = canonical(P, X)
    residuals = reprojection_errors(P, X, x)
    camera = CalibratedCamera(P, method, X, x, np.nan_to_num(residuals, nan=np.inf), inliers, image_size, name)
    behind = (homogeneous(X[inliers]) @ P[2]) <= 0
    if behind.any():
        raise CalibrationError(
            f"the fitted camera {name} puts {int(behind.sum())} calibration point(s) behind it: "
            "the points and pixels do not describe one camera (check their order and units)"
        )
    if not camera.rms_px <= max_rms_px:
        hint = (
            " (the paper's a34 = 1 solve fails when the world origin is near the camera's focal plane: try 'normalized')"
            if method == "paper"
            else ""
        )
        raise CalibrationError(
            f"the {method!r} fit of camera {name} leaves an RMS reprojection error of "
            f"{camera.rms_px:.1f} px (> {max_rms_px:g} px): the 3D points and pixels do not describe "
            f"one camera; check that they are in the same order, in the same units, from one camera{hint}"
        )
    return camera
