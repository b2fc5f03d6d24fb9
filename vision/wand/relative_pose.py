"""The relative pose of two cameras from point correspondences: eight-point, essential matrix, cheirality.

Points are in normalised image coordinates, x^ = K^-1 [u, v, 1]^T, with the nominal intrinsics K (the
Wiimote's 1300 px and (512, 384) to begin with). For the images x1, x2 of one point in cameras 1 and
2 the epipolar constraint is

    x2^T F x1 = 0                                                             (HZ eq. 9.3)

and with exact intrinsics F is the essential matrix E = [t]x R of the motion X2 = R X1 + t.

* `eight_point`: the normalised eight-point algorithm (Hartley & Zisserman, Algorithm 11.1):
  translate each image's points to their centroid and scale them to a mean distance sqrt(2)
  (T1, T2), stack one row kron(x2, x1) per correspondence into A f = 0, take f as the right
  singular vector of A's smallest singular value, enforce rank 2 by zeroing F's smallest singular
  value, and undo the normalisation: F = T2^T F^ T1. Batched: many samples at once (RANSAC).
* `closest_essential`: the essential matrix nearest F in Frobenius norm (HZ section 9.6.1):
  F = U diag(s1, s2, s3) V^T  ->  E = U diag(1, 1, 0) V^T (the scale is free).
* `essential_poses`: the four motions of an essential matrix (HZ Result 9.19): with det U, det V > 0
  and W = [[0, -1, 0], [1, 0, 0], [0, 0, 1]],

      R in {U W V^T, U W^T V^T},     t = +-u3 (the last column of U, ||t|| = 1).

* `relative_pose`: the one of the four with the points in front of both cameras (cheirality):
  each point is triangulated from P1 = [I | 0] and P2 = [R | t] and counted when its depth is
  positive in both.
* `sampson_px`: the first-order geometric distance of a correspondence to F (HZ eq. 11.9),

      d^2 = (x2^T F x1)^2 / ((F x1)_1^2 + (F x1)_2^2 + (F^T x2)_1^2 + (F^T x2)_2^2),

  times the focal length to read it in pixels.

The scale of t is not observable from images: `wiithrow.vision.wand.scale` sets it from the wand.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from wiithrow.vision.errors import DegenerateMotionError
from wiithrow.vision.triangulation import triangulate

_W = np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])


def normalised(pixels: NDArray[np.float64], K: NDArray[np.float64]) -> NDArray[np.float64]:
    """Pixels (..., 2) in normalised image coordinates (..., 2): K^-1 [u, v, 1]^T without the 1."""
    f, s, cx = K[0]
    fy, cy = K[1, 1], K[1, 2]
    y = (pixels[..., 1] - cy) / fy
    x = (pixels[..., 0] - cx - s * y) / f
    return np.stack([x, y], axis=-1)


def _conditioning(points: NDArray[np.float64]) -> NDArray[np.float64]:
    """Hartley's similarity T (B, 3, 3) per batch of points (B, n, 2): centroid to 0, mean distance sqrt(2)."""
    centre = points.mean(axis=1)
    distance = np.linalg.norm(points - centre[:, None, :], axis=2).mean(axis=1)
    scale = np.sqrt(2.0) / np.maximum(distance, 1e-12)
    T = np.zeros((points.shape[0], 3, 3))
    T[:, 0, 0] = T[:, 1, 1] = scale
    T[:, :2, 2] = -scale[:, None] * centre
    T[:, 2, 2] = 1.0
    return T


def eight_point(x1: NDArray[np.float64], x2: NDArray[np.float64]) -> NDArray[np.float64]:
    """Fundamental matrices (B, 3, 3) of B sets of n >= 8 correspondences x1, x2 (B, n, 2), each with
    ||F|| = 1 and rank 2 (the normalised eight-point algorithm; a (n, 2) pair gives (3, 3))."""
    single = x1.ndim == 2
    a = x1[None] if single else x1
    b = x2[None] if single else x2
    T1, T2 = _conditioning(a), _conditioning(b)
    ha = np.einsum("bij,bnj->bni", T1, np.concatenate([a, np.ones(a.shape[:2] + (1,))], axis=2))
    hb = np.einsum("bij,bnj->bni", T2, np.concatenate([b, np.ones(b.shape[:2] + (1,))], axis=2))
    A = (hb[:, :, :, None] * ha[:, :, None, :]).reshape(a.shape[0], a.shape[1], 9)  # rows kron(x2, x1)
    if A.shape[1] < 9:  # a zero row keeps the null space and gives V all nine rows
        A = np.concatenate([A, np.zeros((A.shape[0], 9 - A.shape[1], 9))], axis=1)
    _, _, Vt = np.linalg.svd(A, full_matrices=False)
    F = Vt[:, -1].reshape(-1, 3, 3)
    U, s, Vt = np.linalg.svd(F)
    s[:, 2] = 0.0
    F = np.einsum("bij,bj,bjk->bik", U, s, Vt)
    F = np.einsum("bji,bjk,bkl->bil", T2, F, T1)  # T2^T F T1
    F /= np.linalg.norm(F, axis=(1, 2), keepdims=True)
    out: NDArray[np.float64] = F[0] if single else F
    return out


def closest_essential(F: NDArray[np.float64]) -> NDArray[np.float64]:
    """The essential matrix nearest F (3, 3): equal non-zero singular values, ||E|| = sqrt(2)."""
    U, _, Vt = np.linalg.svd(F)
    E: NDArray[np.float64] = U @ np.diag([1.0, 1.0, 0.0]) @ Vt
    return E


def essential_poses(E: NDArray[np.float64]) -> list[tuple[NDArray[np.float64], NDArray[np.float64]]]:
    """The four (R, t) with E ~ [t]x R, ||t|| = 1 (HZ Result 9.19)."""
    U, _, Vt = np.linalg.svd(E)
    if np.linalg.det(U) < 0:
        U = -U
    if np.linalg.det(Vt) < 0:
        Vt = -Vt
    Ra, Rb = U @ _W @ Vt, U @ _W.T @ Vt
    t = U[:, 2]
    return [(Ra, t), (Ra, -t), (Rb, t), (Rb, -t)]


def relative_pose(
    E: NDArray[np.float64], x1: NDArray[np.float64], x2: NDArray[np.float64]
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """The motion (R, t), X2 = R X1 + t with ||t|| = 1, of E's four that puts most of the
    correspondences x1, x2 (n, 2, normalised) in front of both cameras (cheirality).

    Raises DegenerateMotionError when no candidate puts most points in front (the correspondences
    do not come from one rigid scene seen by two cameras)."""
    P1 = np.hstack([np.eye(3), np.zeros((3, 1))])
    best: tuple[int, NDArray[np.float64], NDArray[np.float64]] | None = None
    for R, t in essential_poses(E):
        P2 = np.hstack([R, t[:, None]])
        X = triangulate(np.stack([P1, P2]), np.stack([x1, x2])).points
        with np.errstate(invalid="ignore"):
            front = int(((X[:, 2] > 0) & ((X @ R.T + t)[:, 2] > 0)).sum())
        if best is None or front > best[0]:
            best = (front, R, t)
    assert best is not None
    if best[0] < 0.9 * len(x1):
        raise DegenerateMotionError(
            f"no relative pose puts the wand in front of both cameras ({best[0]} of {len(x1)} points): "
            "the two cameras' dots do not look like one wand; check the recording"
        )
    return best[1], best[2]


def sampson_px(
    F: NDArray[np.float64], x1: NDArray[np.float64], x2: NDArray[np.float64], focal_px: float
) -> NDArray[np.float64]:
    """Sampson distances (..., n) in pixels of correspondences x1, x2 (n, 2) to F (..., 3, 3) (the
    module docstring's d, x homogeneous). F x1 for every model and point is one batched matrix
    product (F @ x1^T, BLAS): `ends.swap_ransac` scores 1,600 models on 300 frames, for which numpy's
    einsum took 6 times longer."""
    h1 = np.concatenate([x1, np.ones(x1.shape[:-1] + (1,))], axis=-1)
    h2 = np.concatenate([x2, np.ones(x2.shape[:-1] + (1,))], axis=-1)
    Fx1 = np.matmul(F, h1.T)  # (..., 3, n)
    Ftx2 = np.matmul(np.swapaxes(F, -1, -2), h2.T)  # (..., 3, n)
    algebraic = (h2.T * Fx1).sum(axis=-2)  # x2~^T F x1~, (..., n)
    denominator = Fx1[..., 0, :] ** 2 + Fx1[..., 1, :] ** 2 + Ftx2[..., 0, :] ** 2 + Ftx2[..., 1, :] ** 2
    with np.errstate(divide="ignore", invalid="ignore"):
        d = np.sqrt(algebraic**2 / denominator)
    return np.where(np.isfinite(d), d * focal_px, np.inf)
