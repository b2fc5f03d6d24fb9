"""One camera refitted without each of its calibration points, for every point at once.

Leave-one-out (`wiithrow.vision.crossval`) needs, for every point i a camera saw, that camera
fitted to its other points. Refitting n times costs n fits of n points, O(n^2) (300 points took
5.6 s, 2,000 points minutes). Here the fit without point i follows from the full fit in O(1) per
point, in batches of 12 x 12 algebra; every function returns Ps (n, 3, 4), row i the camera
without point i, NaN where that fit does not exist.

**normalized** (exact). `solve_normalized` minimises ||A_n p_n|| over ||p_n|| = 1 in coordinates
normalised by similarities T (pixels) and U (points). A row of eq. 15 in normalised coordinates
is the raw row times T's scale s_T ((T P X~)_1 - u_n (T P X~)_3 = s_T ((P X~)_1 - u (P X~)_3)),
so the normalisation changes only the constraint, not the quadratic form. In the full set's
normalised coordinates (camera P0 = T0 P U0^-1, normal matrix M0 = `dlt_normal_matrix`), the fit
without point i minimises p0^T (M0 - m_i) p0 (m_i: point i's two rows, a rank-2 downdate) over
||vec(t_i P0 u_i^-1)|| = 1, where t_i, u_i are the normalising similarities of the other points,
in closed form: their centroid is (n c - y_i) / (n - 1) and their mean squared distance from it
(sum ||y||^2 - ||y_i||^2) / (n - 1) - ||centroid||^2 (this is why the scaling is by RMS
distance). With B_i^-1 = t_i^-1 (x) u_i^T (row-major vec(A X B) = (A (x) B^T) vec X), p0 =
B_i^-1 q and q is the eigenvector of the smallest eigenvalue of B_i^-T (M0 - m_i) B_i^-1: what
`solve_normalized` computes on the other points, to round-off.

**paper** (exact). The paper's least squares a = argmin ||A a - b|| (eq. 16-18), with a thin QR
A = Q R of the column-scaled A. Deleting point i's two rows A_i (Sherman-Morrison-Woodbury on
A^T A):  a_-i = a + R^-1 Q_i^T (I - Q_i Q_i^T)^-1 r_i,  r_i = A_i a - b_i, where Q_i Q_i^T is
the point's 2 x 2 leverage (1: the others do not determine a; NaN).

**refined, robust** (one Gauss-Newton step; approximate). The maximum-likelihood P has no closed
form. At the full fit P^ (gradient g = sum_j J_j^T r_j ~ 0, Gauss-Newton matrix H = J^T J over
the inliers, J_j = dr_j/dP restricted to the 11 directions orthogonal to P^, since P's scale is
free), the Gauss-Newton step of the other points' problem is

    delta_i = -(H - J_i^T J_i)^-1 (g - J_i^T r_i)
            = -delta_0 + W_i [r_i - S_i^-1 (J_i delta_0 - L_i r_i)],

with delta_0 = H^-1 g, J = Q R, W_i = R^-1 Q_i^T = H^-1 J_i^T, L_i = Q_i Q_i^T, S_i = I - L_i
(Woodbury again); P_-i = P^ + delta_i. Removing a point moves the optimum by O(1/n), and one
Gauss-Newton step from O(1/n) away lands within O(1/n^2) of it (small residuals: Gauss-Newton
converges nearly quadratically), so the held-out errors differ from refitting by far less than
they differ from each other (`tests/vision/test_crossval.py` bounds it: within 1 % per point and
0.1 % in the mean at 30 points; measured at most 0.23 % and 0.011 % over five draws). A camera
with fewer than REFIT_BELOW = 20 points, where the step is cruder and refitting cheap, is
refitted instead (`refit_each`). For `robust` the fit is the refinement
over its inliers and the consensus set is taken as unchanged by removing one point: an inlier
gets the step above, an outlier (not in the fit) leaves it where it is.

Not repeated per point: `calibrate`'s checks of a finished fit (RMS at most 20 px, the points in
front of the camera). The full fit passes them, and a fit that moves by O(1/n) when one point
goes keeps passing them unless the data are on the edge of failing.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray
from scipy.linalg import solve_triangular

from wiithrow.vision.dlt import CalibratedCamera, Method, calibrate
from wiithrow.vision.dlt_solvers import (
    MIN_POINTS,
    RANK_RATIO,
    dlt_normal_matrix,
    normalizing_transform,
    paper_system,
)
from wiithrow.vision.errors import CalibrationError
from wiithrow.vision.geometry import homogeneous

#: Below this many points a refined or robust camera is refitted without each point (at most 19
#: fits of at most 19 points: a fraction of a second), where one Gauss-Newton step would be off
#: by up to 17 % per point (7 points) or 2 % (10); from 20 points on the step is within 0.3 %.
REFIT_BELOW = 20

#: Folds per batch of 12 x 12 matrices (bounds the memory: ~12 MB per batch).
BATCH = 2048


def _nan_folds(n: int) -> NDArray[np.float64]:
    return np.full((n, 3, 4), np.nan)


def _fold_similarities(points: NDArray[np.float64], rms_distance: float) -> NDArray[np.float64]:
    """For each i, the normalising similarity (d+1 x d+1) of `points` without point i (module
    docstring, **normalized**). `points` (n, d) are already normalised (centroid ~0)."""
    n, d = points.shape
    m = n - 1
    centroid = (points.sum(axis=0) - points) / m  # (n, d): centroid of the others
    sq_total = float(np.sum(points * points))
    mean_sq = (sq_total - np.sum(points * points, axis=1)) / m - np.sum(centroid * centroid, axis=1)
    scale = rms_distance / np.sqrt(mean_sq)
    S = np.zeros((n, d + 1, d + 1))
    S[:, np.arange(d), np.arange(d)] = scale[:, None]
    S[:, :d, d] = -scale[:, None] * centroid
    S[:, d, d] = 1.0
    return S


def _similarity_inverse(S: NDArray[np.float64]) -> NDArray[np.float64]:
    """Inverses of similarities [[s I, t], [0, 1]] (k, d+1, d+1): [[I / s, -t / s], [0, 1]]."""
    d = S.shape[1] - 1
    s = S[:, 0, 0]
    inv = np.zeros_like(S)
    inv[:, np.arange(d), np.arange(d)] = (1.0 / s)[:, None]
    inv[:, :d, d] = -S[:, :d, d] / s[:, None]
    inv[:, d, d] = 1.0
    return inv


def _point_rows(Xn: NDArray[np.float64], xn: NDArray[np.float64]) -> NDArray[np.float64]:
    """Each point's two rows of A p = 0 (k, 2, 12): [X~, 0, -u X~] and [0, X~, -v X~]."""
    rows = np.zeros((Xn.shape[0], 2, 12))
    rows[:, 0, 0:4] = Xn
    rows[:, 0, 8:12] = -xn[:, :1] * Xn
    rows[:, 1, 4:8] = Xn
    rows[:, 1, 8:12] = -xn[:, 1:2] * Xn
    return rows


def without_each_normalized(world: NDArray[np.float64], image: NDArray[np.float64]) -> NDArray[np.float64]:
    """`solve_normalized` on all points but i, for every i (exact; module docstring)."""
    n = world.shape[0]
    if n - 1 < MIN_POINTS:
        return _nan_folds(n)
    U0 = normalizing_transform(world, np.sqrt(3.0))
    T0 = normalizing_transform(image, np.sqrt(2.0))
    Xn = homogeneous(world) @ U0.T
    xn = (homogeneous(image) @ T0.T)[:, :2]
    M0 = dlt_normal_matrix(Xn, xn)
    u = _fold_similarities(Xn[:, :3], np.sqrt(3.0))
    t_inv = _similarity_inverse(_fold_similarities(xn, np.sqrt(2.0)))
    T0_inv = np.linalg.inv(T0)
    out = _nan_folds(n)
    for lo in range(0, n, BATCH):
        k = slice(lo, min(lo + BATCH, n))
        rows = _point_rows(Xn[k], xn[k])
        M = M0 - np.einsum("kri,krj->kij", rows, rows)
        # B^-1 = t^-1 (x) u^T, as a (k, 12, 12) matrix: [4a + b, 4c + d] = t^-1[a, c] u^T[b, d]
        B_inv = np.einsum("kac,kdb->kabcd", t_inv[k], u[k]).reshape(-1, 12, 12)
        N = B_inv.transpose(0, 2, 1) @ M @ B_inv
        values, vectors = np.linalg.eigh(N)
        P0 = np.einsum("kij,kj->ki", B_inv, vectors[:, :, 0]).reshape(-1, 3, 4)
        P = T0_inv @ P0 @ U0
        P[~(values[:, 1] > RANK_RATIO * values[:, -1])] = np.nan
        out[k] = P
    return out


def without_each_paper(world: NDArray[np.float64], image: NDArray[np.float64]) -> NDArray[np.float64]:
    """`solve_paper` on all points but i, for every i (exact; module docstring)."""
    n = world.shape[0]
    if n - 1 < MIN_POINTS:
        return _nan_folds(n)
    A, b, D = paper_system(world, image)
    Q, R = np.linalg.qr(A)
    a = np.linalg.solve(R, Q.T @ b)
    r = (A @ a - b).reshape(n, 2)
    Qi = Q.reshape(n, 2, 11)
    S = np.eye(2) - Qi @ Qi.transpose(0, 2, 1)
    W = solve_triangular(R, Q.T).reshape(11, n, 2).transpose(1, 0, 2)  # R^-1 Q_i^T, (n, 11, 2)
    ok = np.linalg.det(S) > 1e-12
    step = np.zeros((n, 2))
    step[ok] = np.linalg.solve(S[ok], r[ok][:, :, None])[:, :, 0]
    folds = D * (a + np.einsum("nij,nj->ni", W, step))
    out = np.concatenate([folds, np.ones((n, 1))], axis=1).reshape(n, 3, 4)
    out[~ok] = np.nan
    return out


def without_each_refined(camera: CalibratedCamera) -> NDArray[np.float64]:
    """The fitted `camera` (refined or robust) on all its points but i, for every i, by one
    Gauss-Newton step from the full fit over its inliers (approximate; module docstring)."""
    P = camera.P
    n = camera.world.shape[0]
    inliers = np.flatnonzero(camera.inliers)
    m = inliers.size
    if m - 1 < MIN_POINTS:
        return _nan_folds(n)
    Xh = homogeneous(camera.world[inliers])
    proj = Xh @ P.T
    w = proj[:, 2:3]
    uv = proj[:, :2] / w
    r = uv - camera.image[inliers]  # (m, 2): model - data
    dr_dP = np.zeros((m, 2, 12))
    dr_dP[:, 0, 0:4] = Xh / w
    dr_dP[:, 0, 8:12] = -uv[:, :1] * Xh / w
    dr_dP[:, 1, 4:8] = Xh / w
    dr_dP[:, 1, 8:12] = -uv[:, 1:2] * Xh / w
    # the 11 directions orthogonal to P (its scale is free): the rest of an orthonormal basis
    E = np.linalg.svd(P.reshape(1, 12))[2][1:].T  # (12, 11)
    J = dr_dP.reshape(2 * m, 12) @ E
    Q, R = np.linalg.qr(J)
    g = J.T @ r.reshape(-1)
    delta0 = solve_triangular(R, solve_triangular(R, g, trans="T"))  # H^-1 g, H = R^T R
    Qi = Q.reshape(m, 2, 11)
    L = Qi @ Qi.transpose(0, 2, 1)
    S = np.eye(2) - L
    W = solve_triangular(R, Q.T).reshape(11, m, 2).transpose(1, 0, 2)  # H^-1 J_i^T, (m, 11, 2)
    Jd = (J @ delta0).reshape(m, 2)
    ok = np.linalg.det(S) > 1e-12
    inner = np.zeros((m, 2))
    rhs = Jd - np.einsum("mij,mj->mi", L, r)
    inner[ok] = r[ok] - np.linalg.solve(S[ok], rhs[ok][:, :, None])[:, :, 0]
    deltas = np.broadcast_to(-delta0, (n, 11)).copy()  # an outlier leaves the fit as it is
    deltas[inliers] = -delta0 + np.einsum("mij,mj->mi", W, inner)
    out: NDArray[np.float64] = P + (deltas @ E.T).reshape(n, 3, 4)
    bad = np.zeros(n, dtype=bool)
    bad[inliers[~ok]] = True
    out[bad] = np.nan
    return out


def refit_each(method: Method, camera: CalibratedCamera) -> NDArray[np.float64]:
    """The camera refitted by `calibrate` without each point in turn (exact; n fits)."""
    n = camera.world.shape[0]
    out = _nan_folds(n)
    for i in range(n):
        others = np.arange(n) != i
        try:
            out[i] = calibrate(camera.world[others], camera.image[others], method).P
        except CalibrationError:
            pass
    return out


def without_each(method: Method, camera: CalibratedCamera) -> NDArray[np.float64]:
    """The camera fitted by `method` to `camera.world`/`camera.image`, without each point in turn:
    in closed form, or refitted when that is cheap and the one-step approximation is not (a
    refined or robust camera with fewer than REFIT_BELOW points)."""
    if method == "normalized":
        return without_each_normalized(camera.world, camera.image)
    if method == "paper":
        return without_each_paper(camera.world, camera.image)
    if camera.world.shape[0] < REFIT_BELOW:
        return refit_each(method, camera)
    return without_each_refined(camera)
