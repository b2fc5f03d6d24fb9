"""N-view triangulation: 3D points from their pixels in C >= 2 calibrated cameras, many at once.

The paper's eq. 11-13: with P_c = [p1; p2; p3] (rows) and pixel (u, v) in camera c, eq. 15 gives
two equations linear in the point X:

    (u p3 - p1) . [X; 1] = 0,        (v p3 - p2) . [X; 1] = 0.

Stacking them for every camera that sees the point gives A X = B (A: 2C' x 3), solved by the left
pseudo-inverse X = (A^T A)^-1 A^T B. Each P is first scaled so that ||p3[:3]|| = 1: then a row's
residual is the pixel error times the point's depth in that camera, so cameras are weighted alike
(`docs/calibration.md`, "Calibration and triangulation pitfalls"). There is no Python loop per
point: the 3x3 normal equations of every point are built and solved in closed form (by the
adjugate) in one compiled pass (`wiithrow.vision.kernels`).

`refine=True` then runs Gauss-Newton on the reprojection error: with x = P [X; 1] = (a, b, w),
u = a / w, the Jacobian rows are (p1 - u p3) / w and (p2 - v p3) / w -- the linear rows divided by
the depth, i.e. the linear solve re-weighted by 1/depth, iterated to the maximum-likelihood point.

A camera that did not see a point has NaN there; a point seen by fewer than two cameras (or seen
from a degenerate geometry, such as a point on the baseline) comes out NaN.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numpy.typing import ArrayLike, NDArray

from wiithrow.vision import kernels
from wiithrow.vision.errors import TriangulationError


class Triangulation(NamedTuple):
    """Triangulated points (N, 3), their RMS reprojection error over the views that saw them
    (N,) in pixels, and how many views saw each point (N,)."""

    points: NDArray[np.float64]
    reprojection_error_px: NDArray[np.float64]
    n_views: NDArray[np.int64]


def _check(Ps: ArrayLike, image: ArrayLike) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    P = np.asarray(Ps, dtype=float)
    x = np.asarray(image, dtype=float)
    if P.ndim != 3 or P.shape[1:] != (3, 4):
        raise TriangulationError(f"projection matrices must have shape (C, 3, 4), got {P.shape}")
    if P.shape[0] < 2:
        raise TriangulationError(f"triangulation needs at least 2 cameras, got {P.shape[0]}")
    if x.ndim == 2 and x.shape == (P.shape[0], 2):
        x = x[:, None, :]
    if x.ndim != 3 or x.shape[0] != P.shape[0] or x.shape[2] != 2:
        raise TriangulationError(f"image points must have shape (C, N, 2) with C = {P.shape[0]} cameras, got {x.shape}")
    if not np.all(np.isfinite(P)):
        raise TriangulationError("a projection matrix contains NaN or inf")
    scale = np.linalg.norm(P[:, 2, :3], axis=1)
    if np.any(scale == 0):
        raise TriangulationError("a projection matrix has a zero third row: it is not a camera")
    return np.ascontiguousarray(P / scale[:, None, None]), np.ascontiguousarray(x)


def triangulate(
    Ps: ArrayLike,
    image: ArrayLike,
    *,
    refine: bool = False,
    iterations: int = 5,
) -> Triangulation:
    """Triangulate N points seen by C >= 2 cameras.

    Args:
        Ps: (C, 3, 4) projection matrices (any scale, any sign).
        image: (C, N, 2) pixels, NaN where a camera did not see the point.
        refine: add Gauss-Newton steps on the reprojection error to the linear solution.
        iterations: how many, with `refine`.

    Returns:
        A `Triangulation`: points (N, 3) in the cameras' common frame (the calibration's unit, m;
        NaN where fewer than two cameras saw the point), RMS reprojection error (px) and view counts.
    """
    P, x = _check(Ps, image)
    n = x.shape[1]
    X = np.empty((n, 3))
    views = np.empty(n, dtype=np.int64)
    kernels.triangulate_linear(P, x, X, views)
    if refine:
        kernels.gauss_newton(P, x, X, iterations)
    error = np.empty(n)
    kernels.reprojection_rms(P, x, X, error)
    return Triangulation(X, error, views)
