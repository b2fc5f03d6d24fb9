"""N-view triangulation: 3D points from their pixels in C >= 2 calibrated cameras, many at once.

The paper's eq. 11-13: with P_c = [p1; p2; p3] (rows) and pixel (u, v) in camera c, eq. 15 gives
two equations linear in the point X:

    (u p3 - p1) . [X; 1] = 0,        (v p3 - p2) . [X; 1] = 0.

Stacking them for every camera that sees the point gives A X = B (A: 2C' x 3), solved by the left
pseudo-inverse X = (A^T A)^-1 A^T B. Each P is first scaled so that ||p3[:3]|| = 1: then a row's
residual is the pixel error times the point's depth in that camera, so cameras are weighted alike
(DESIGN.md, "Calibration and triangulation pitfalls"). Everything is vectorised over points: the
3x3 normal equations of all N points are built with array arithmetic and solved in closed form
(Cramer's rule), so there is no Python loop per point.

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

from vision.errors import TriangulationError

#: Determinant (relative) below which a point's normal equations are called singular.
SINGULAR_RATIO = 1e-12


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
        raise TriangulationError(
            f"image points must have shape (C, N, 2) with C = {P.shape[0]} cameras, got {x.shape}"
        )
    if not np.all(np.isfinite(P)):
        raise TriangulationError("a projection matrix contains NaN or inf")
    scale = np.linalg.norm(P[:, 2, :3], axis=1)
    if np.any(scale == 0):
        raise TriangulationError("a projection matrix has a zero third row: it is not a camera")
    return P / scale[:, None, None], x


def _solve_symmetric3(H: NDArray[np.float64], g: NDArray[np.float64]) -> NDArray[np.float64]:
    """Solve H x = g for N symmetric 3x3 systems given as H (6, N) = (h00, h01, h02, h11, h12, h22)
    and g (3, N), by the adjugate: x = adj(H) g / det(H). Singular systems give NaN."""
    h00, h01, h02, h11, h12, h22 = H
    c00 = h11 * h22 - h12 * h12
    c01 = h02 * h12 - h01 * h22
    c02 = h01 * h12 - h02 * h11
    c11 = h00 * h22 - h02 * h02
    c12 = h01 * h02 - h00 * h12
    c22 = h00 * h11 - h01 * h01
    det = h00 * c00 + h01 * c01 + h02 * c02
    trace = h00 + h11 + h22
    with np.errstate(divide="ignore", invalid="ignore"):
        inv_det = np.where(np.abs(det) > SINGULAR_RATIO * trace**3, 1.0 / det, np.nan)
        g0, g1, g2 = g
        return np.stack(
            [
                (c00 * g0 + c01 * g1 + c02 * g2) * inv_det,
                (c01 * g0 + c11 * g1 + c12 * g2) * inv_det,
                (c02 * g0 + c12 * g1 + c22 * g2) * inv_det,
            ],
            axis=1,
        )


def _normal_equations(
    rows: tuple[NDArray[np.float64], ...], rhs: tuple[NDArray[np.float64], ...]
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Accumulate A^T A (6 unique entries) and A^T B over cameras and rows.

    `rows` holds arrays (C, N, 3) of equation coefficients, `rhs` arrays (C, N) of right-hand sides;
    rows of unseen observations are all zero and add nothing.
    """
    H = np.zeros((6, rows[0].shape[1]))
    g = np.zeros((3, rows[0].shape[1]))
    for a, b in zip(rows, rhs):
        a0, a1, a2 = a[..., 0], a[..., 1], a[..., 2]
        H[0] += (a0 * a0).sum(0)
        H[1] += (a0 * a1).sum(0)
        H[2] += (a0 * a2).sum(0)
        H[3] += (a1 * a1).sum(0)
        H[4] += (a1 * a2).sum(0)
        H[5] += (a2 * a2).sum(0)
        g[0] += (a0 * b).sum(0)
        g[1] += (a1 * b).sum(0)
        g[2] += (a2 * b).sum(0)
    return H, g


def triangulate(
    Ps: ArrayLike,
    image: ArrayLike,
    *,
    refine: bool = False,
    iterations: int = 5,
) -> Triangulation:
    """Triangulate N points seen by C >= 2 cameras.

    Ps: (C, 3, 4) projection matrices (any scale, any sign); image: (C, N, 2) pixels, NaN where a
    camera did not see the point. Returns a `Triangulation`: points (N, 3) in the cameras' common
    frame (NaN where fewer than two cameras saw the point), RMS reprojection error (px) and view
    counts. `refine=True` adds `iterations` Gauss-Newton steps on the reprojection error.
    """
    P, x = _check(Ps, image)
    seen = np.isfinite(x).all(axis=2)  # (C, N)
    n_views = seen.sum(axis=0)
    u = np.where(seen, x[..., 0], 0.0)
    v = np.where(seen, x[..., 1], 0.0)
    w = seen.astype(float)
    p1, p2, p3 = P[:, 0, None, :], P[:, 1, None, :], P[:, 2, None, :]  # (C, 1, 4)
    row_u = (u[..., None] * p3 - p1) * w[..., None]  # (C, N, 4)
    row_v = (v[..., None] * p3 - p2) * w[..., None]
    H, g = _normal_equations((row_u[..., :3], row_v[..., :3]), (-row_u[..., 3], -row_v[..., 3]))
    X = _solve_symmetric3(H, g)
    X[n_views < 2] = np.nan

    if refine:
        for _ in range(iterations):
            X = _gauss_newton_step(P, u, v, w, X)

    error = _rms_reprojection(P, x, seen, X)
    return Triangulation(X, error, n_views.astype(np.int64))


def _gauss_newton_step(
    P: NDArray[np.float64], u: NDArray[np.float64], v: NDArray[np.float64], w: NDArray[np.float64], X: NDArray[np.float64]
) -> NDArray[np.float64]:
    """One Gauss-Newton step on sum_c ||(u_c, v_c) - pi(P_c, X)||^2 for every point at once."""
    Xh = np.concatenate([X, np.ones((X.shape[0], 1))], axis=1)
    proj = np.einsum("cij,nj->cni", P, Xh)  # (C, N, 3)
    depth = proj[..., 2]
    with np.errstate(divide="ignore", invalid="ignore"):
        inv = np.where(w > 0, 1.0 / depth, 0.0)
        uh, vh = proj[..., 0] * inv, proj[..., 1] * inv
        # Jacobian rows d(u_hat)/dX = (p1 - u_hat p3) / w, residual r = u_hat - u
        Ju = (P[:, 0, None, :3] - uh[..., None] * P[:, 2, None, :3]) * inv[..., None]
        Jv = (P[:, 1, None, :3] - vh[..., None] * P[:, 2, None, :3]) * inv[..., None]
        H, g = _normal_equations((Ju, Jv), (-(uh - u) * w, -(vh - v) * w))
        step = _solve_symmetric3(H, g)
    return np.where(np.isfinite(step), X + step, X)


def _rms_reprojection(
    P: NDArray[np.float64], x: NDArray[np.float64], seen: NDArray[np.bool_], X: NDArray[np.float64]
) -> NDArray[np.float64]:
    Xh = np.concatenate([X, np.ones((X.shape[0], 1))], axis=1)
    proj = np.einsum("cij,nj->cni", P, Xh)
    with np.errstate(divide="ignore", invalid="ignore"):
        uv = proj[..., :2] / proj[..., 2:3]
        sq = np.where(seen, ((uv - x) ** 2).sum(axis=2), 0.0)
        return np.sqrt(sq.sum(axis=0) / seen.sum(axis=0))
