"""The solves of the Direct Linear Transform: a camera's P from N >= 6 known points and their pixels.

Each function fits P to world points (N, 3) and their pixels (N, 2) that `dlt.calibrate` has
checked (the methods, their equations and when each one is right: the `dlt` module docstring):

- `solve_paper`: the paper's p34 = 1 pseudo-inverse (eq. 16-18);
- `solve_normalized`: Hartley's normalised homogeneous DLT, by the 12 x 12 normal equations;
- `refine`: Levenberg-Marquardt on the reprojection error over P's 11 degrees of freedom,
  P = K [R | -R C] with R = exp([w]x) R0 (optionally with a robust loss);
- `solve_robust`: RANSAC over minimal 6-point samples, a Cauchy-loss refinement, a refit on the
  inliers.

`canonical` fixes P's scale and sign: ||P[2, :3]|| = 1 and the points in front (w > 0).
"""

from __future__ import annotations

from typing import Literal

import numpy as np
from numpy.typing import NDArray
from scipy.optimize import least_squares

from wiithrow.vision.errors import CalibrationError
from wiithrow.vision.geometry import decompose, homogeneous, project, reprojection_errors, rodrigues

#: The losses of `refine`: "linear" is plain least squares, the others down-weight large residuals.
Loss = Literal["linear", "soft_l1", "huber", "cauchy", "arctan"]

MIN_POINTS = 6
#: Smallest/largest singular value of the centred world points below which they are flat.
DEGENERACY_RATIO = 1e-3
#: Residual (px) above which the robust method calls a point an outlier.
ROBUST_INLIER_PX = 6.0


# --------------------------------------------------------------------------------------------
# Linear solutions


def normalizing_transform(points: NDArray[np.float64], rms_distance: float) -> NDArray[np.float64]:
    """Similarity T that moves `points` to their centroid and scales them to RMS distance
    `rms_distance` from it (sqrt(2) for pixels, sqrt(3) for 3D points). The RMS rather than the
    mean distance: both condition the system alike (Hartley), and the RMS of the points left
    after removing one has a closed form, which the leave-one-out of `dlt_loo` relies on."""
    d = points.shape[1]
    centroid = points.mean(axis=0)
    spread = float(np.sqrt(np.mean(np.sum((points - centroid) ** 2, axis=1))))
    s = rms_distance / spread if spread > 0 else 1.0
    T = np.eye(d + 1)
    T[:d, :d] *= s
    T[:d, d] = -s * centroid
    return T


def dlt_normal_matrix(X: NDArray[np.float64], x: NDArray[np.float64]) -> NDArray[np.float64]:
    """M = A^T A (12 x 12) of the homogeneous system A p = 0 of eq. 15, without forming A.

    Point j (X~ = X_j homogeneous, 4-vector; pixel (u, v)) gives the rows
    a = [X~, 0, -u X~] and b = [0, X~, -v X~], so with S_w = sum_j w_j X~_j X~_j^T (4 x 4):

        M = [[ S_1,    0,    -S_u         ],
             [ 0,      S_1,  -S_v         ],
             [ -S_u,  -S_v,   S_(u^2+v^2) ]]

    X: (N, 4) homogeneous points, x: (N, 2) pixels; memory O(N) for the weighted copies only.
    """
    u, v = x[:, 0], x[:, 1]
    S1 = X.T @ X
    Su = (X * u[:, None]).T @ X
    Sv = (X * v[:, None]).T @ X
    Sw = (X * (u * u + v * v)[:, None]).T @ X
    M = np.zeros((12, 12))
    M[0:4, 0:4] = M[4:8, 4:8] = S1
    M[0:4, 8:12] = M[8:12, 0:4] = -Su
    M[4:8, 8:12] = M[8:12, 4:8] = -Sv
    M[8:12, 8:12] = Sw
    return M


#: The second smallest eigenvalue of the normalised normal matrix, relative to the largest, below
#: which the system has more than one solution (a singular-value ratio of 3e-7; round-off in M
#: is ~1e-15 of the largest eigenvalue, so a truly rank-deficient system lands far below).
RANK_RATIO = 1e-13


def smallest_eigenvector(M: NDArray[np.float64]) -> tuple[NDArray[np.float64], bool]:
    """The unit eigenvector of the smallest eigenvalue of the symmetric M, and whether the second
    smallest is clear of zero (False: rank-deficient, see RANK_RATIO)."""
    values, vectors = np.linalg.eigh(M)
    return vectors[:, 0], bool(values[1] > RANK_RATIO * values[-1])


def solve_normalized(world: NDArray[np.float64], image: NDArray[np.float64]) -> NDArray[np.float64]:
    """Hartley-normalised homogeneous DLT: P = T^-1 P_n U, with p_n = vec(P_n) minimising
    ||A_n p_n|| over ||p_n|| = 1: the eigenvector of the smallest eigenvalue of the 12 x 12 normal
    matrix A_n^T A_n (`dlt_normal_matrix`; the right singular vector of A_n's smallest singular
    value, found in O(N) time and O(1) memory beyond the points). The normalisation keeps A_n well
    conditioned, so squaring it costs no accuracy that matters (the VGG house test holds)."""
    U = normalizing_transform(world, np.sqrt(3.0))
    T = normalizing_transform(image, np.sqrt(2.0))
    Xn = homogeneous(world) @ U.T
    xn = (homogeneous(image) @ T.T)[:, :2]
    p, full_rank = smallest_eigenvector(dlt_normal_matrix(Xn, xn))
    if not full_rank:
        raise CalibrationError(
            "the calibration system is rank-deficient (more than one camera fits the points): "
            "the points are degenerate for a DLT; spread them through the field of view and in depth"
        )
    return np.asarray(np.linalg.solve(T, p.reshape(3, 4) @ U), dtype=np.float64)


def paper_system(
    world: NDArray[np.float64], image: NDArray[np.float64]
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """The paper's A a = b (eq. 16-17) with A's columns scaled to unit norm: (A D, b, D), D the
    diagonal of the scales as a vector. The scaling changes nothing in the least-squares solution
    (a = D a') but keeps the factorisation accurate where the columns differ by orders of magnitude."""
    n = world.shape[0]
    X = homogeneous(world)
    A = np.zeros((2 * n, 11))
    A[0::2, 0:4] = X
    A[0::2, 8:11] = -image[:, :1] * world
    A[1::2, 4:8] = X
    A[1::2, 8:11] = -image[:, 1:2] * world
    norms = np.linalg.norm(A, axis=0)
    D = 1.0 / np.where(norms > 0, norms, 1.0)
    return A * D, image.reshape(-1), D


def solve_paper(world: NDArray[np.float64], image: NDArray[np.float64]) -> NDArray[np.float64]:
    """The paper's eq. 16-18: p34 = 1 and a = pinv(A) b over the 11 remaining entries, computed
    by a QR factorisation of the column-scaled A (the same least-squares solution, stably)."""
    A, b, D = paper_system(world, image)
    Q, R = np.linalg.qr(A)
    a = D * np.linalg.solve(R, Q.T @ b)
    return np.append(a, 1.0).reshape(3, 4)


def canonical(P: NDArray[np.float64], world: NDArray[np.float64]) -> NDArray[np.float64]:
    """Scale P so that ||P[2, :3]|| = 1 and the points lie in front (w = depth > 0, median)."""
    P = P / np.linalg.norm(P[2, :3])
    w = homogeneous(world) @ P[2]
    return -P if np.median(w) < 0 else P


# --------------------------------------------------------------------------------------------
# Non-linear refinement on the reprojection error


def compose_camera(params: NDArray[np.float64], R0: NDArray[np.float64]) -> NDArray[np.float64]:
    """P = K [R | -R C] from (fx, skew, cx, fy, cy, w, C) with R = exp([w]x) R0."""
    fx, skew, cx, fy, cy = params[:5]
    K = np.array([[fx, skew, cx], [0.0, fy, cy], [0.0, 0.0, 1.0]])
    R = rodrigues(params[5:8]) @ R0
    C = params[8:11]
    return K @ np.hstack([R, (-R @ C)[:, None]])


def compose_jacobian(params: NDArray[np.float64], R0: NDArray[np.float64]) -> NDArray[np.float64]:
    """dP/dtheta (12 x 11) by central differences of `compose_camera` (a 3x4 product: cheap, accurate)."""
    J = np.empty((12, params.size))
    for k in range(params.size):
        h = 1e-6 * max(1.0, abs(params[k]))
        step = np.zeros_like(params)
        step[k] = h
        J[:, k] = (compose_camera(params + step, R0) - compose_camera(params - step, R0)).ravel() / (2 * h)
    return J


def refine(
    P0: NDArray[np.float64],
    world: NDArray[np.float64],
    image: NDArray[np.float64],
    *,
    loss: Loss = "linear",
    f_scale_px: float = 1.0,
) -> NDArray[np.float64]:
    """Minimise sum_i rho(||x_i - pi(P, X_i)||^2) over the 11 degrees of freedom of P.

    `loss="linear"` is Levenberg-Marquardt on the plain reprojection error (maximum likelihood
    under Gaussian noise); a robust loss ("cauchy", "soft_l1", ...) down-weights large residuals
    with scale `f_scale_px`, which is iteratively re-weighted least squares in effect.
    """
    d = decompose(canonical(P0, world))
    K = d.K
    x0 = np.concatenate([[K[0, 0], K[0, 1], K[0, 2], K[1, 1], K[1, 2]], np.zeros(3), d.center])
    Xh = homogeneous(world)

    def residuals(params: NDArray[np.float64]) -> NDArray[np.float64]:
        r = project(compose_camera(params, d.R), world) - image
        return np.nan_to_num(r, nan=1e6).ravel()

    def jacobian(params: NDArray[np.float64]) -> NDArray[np.float64]:
        # Chain rule J = dr/dP . dP/dtheta. With (a, b, w) = P X~ and u = a / w:
        #   du/dP_0j = X~_j / w,  du/dP_2j = -u X~_j / w,  dv/dP_1j = X~_j / w,  dv/dP_2j = -v X~_j / w
        proj = Xh @ compose_camera(params, d.R).T
        w = proj[:, 2:3]
        u, v = proj[:, 0:1] / w, proj[:, 1:2] / w
        dr_dP = np.zeros((world.shape[0], 2, 12))
        dr_dP[:, 0, 0:4] = Xh / w
        dr_dP[:, 0, 8:12] = -u * Xh / w
        dr_dP[:, 1, 4:8] = Xh / w
        dr_dP[:, 1, 8:12] = -v * Xh / w
        return dr_dP.reshape(-1, 12) @ compose_jacobian(params, d.R)

    method: Literal["lm", "trf"] = "lm" if loss == "linear" and residuals(x0).size >= x0.size else "trf"
    result = least_squares(residuals, x0, jac=jacobian, method=method, loss=loss, f_scale=f_scale_px, x_scale="jac")
    P = compose_camera(result.x, d.R)
    # Keep the refinement only if it did not make things worse (it never should, but a bad start can).
    if np.sum(reprojection_errors(P, world, image) ** 2) > np.sum(reprojection_errors(P0, world, image) ** 2):
        return P0
    return P


# --------------------------------------------------------------------------------------------
# Robust fit


def solve_robust(
    world: NDArray[np.float64],
    image: NDArray[np.float64],
    rng: np.random.Generator,
    *,
    inlier_px: float = ROBUST_INLIER_PX,
    max_trials: int = 500,
    confidence: float = 0.999,
) -> tuple[NDArray[np.float64], NDArray[np.bool_]]:
    """RANSAC over 6-point samples, Cauchy-loss refinement, then a plain refit on the inliers.

    Returns P and the inlier mask. The number of trials adapts to the inlier ratio w found so far:
    k = log(1 - confidence) / log(1 - w^6).
    """
    n = world.shape[0]
    best_inliers = np.zeros(n, dtype=bool)
    best_cost = np.inf
    trials, needed = 0, max_trials
    while trials < min(needed, max_trials):
        trials += 1
        sample = rng.choice(n, MIN_POINTS, replace=False)
        Xs = world[sample]
        s = np.linalg.svd(Xs - Xs.mean(axis=0), compute_uv=False)
        if s[2] <= DEGENERACY_RATIO * s[0]:
            continue
        try:
            P = solve_normalized(Xs, image[sample])
        except CalibrationError:
            continue
        err = reprojection_errors(P, world, image)
        err = np.where(np.isfinite(err), err, np.inf)
        inliers = err < inlier_px
        cost = np.minimum(err, inlier_px).sum()  # MSAC: truncated cost, ties broken by accuracy
        if cost < best_cost and inliers.sum() >= MIN_POINTS:
            best_cost, best_inliers = cost, inliers
            w = inliers.mean()
            needed = int(np.ceil(np.log(1 - confidence) / np.log(max(1 - w**MIN_POINTS, 1e-12))))
    if best_inliers.sum() < MIN_POINTS:
        raise CalibrationError(
            f"robust calibration found no camera that fits {MIN_POINTS} or more points within "
            f"{inlier_px:g} px: the points do not describe one camera"
        )
    P = solve_normalized(world[best_inliers], image[best_inliers])
    P = refine(P, world, image, loss="cauchy", f_scale_px=inlier_px / 3)
    err = reprojection_errors(P, world, image)
    inliers = np.isfinite(err) & (err < inlier_px)
    if inliers.sum() < MIN_POINTS:
        inliers = best_inliers
    P = refine(solve_normalized(world[inliers], image[inliers]), world[inliers], image[inliers])
    err = reprojection_errors(P, world, image)
    return P, np.isfinite(err) & (err < inlier_px)
