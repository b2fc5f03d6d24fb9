"""The projective geometry every part of vision shares, each formula once.

A camera maps a point X = (x, y, z) to the pixel (u, v) by its 3x4 projection matrix P, with
X~ = [X; 1] the point in homogeneous coordinates:

    (a, b, w) = P X~,        u = a / w,        v = b / w                                (paper eq. 15)

w is the point's depth when P is scaled so that ||P[2, :3]|| = 1 with the points in front of the
camera at w > 0 (as `calibrate` and `WiimoteCamera` make it); for an arbitrary P (any scale, any
sign) only w = 0, a point in the camera's focal plane, has no image.

Rotations are parametrised by axis-angle vectors w (the angle ||w|| about the axis w / ||w||):

    R = exp([w]x) = I + sin(a) [k]x + (1 - cos(a)) [k]x^2,     a = ||w||,  k = w / a    (Rodrigues)

with [v]x the cross-product matrix, [v]x y = v x y. A rotation matrix's unit quaternion
(x, y, z, w) (the ROS / Foxglove order) is `quaternion_xyzw`.

A finite camera's P splits into intrinsics, rotation and translation, P = lambda K [R | t]
(`decompose`, by an RQ decomposition of its left 3x3 block).

The compiled kernels (`wiithrow.vision.kernels`) compute the same projection point by point in
`kernels.project_point`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import scipy.linalg
from numpy.typing import ArrayLike, NDArray

from wiithrow.vision.errors import CalibrationError

#: |w| below this is a point in the focal plane of an arbitrary P: its pixel is NaN.
AT_INFINITY = 1e-12


def skew(v: ArrayLike) -> NDArray[np.float64]:
    """The cross-product matrix [v]x of a 3-vector: [v]x y = v x y."""
    x, y, z = np.asarray(v, dtype=float).reshape(3)
    return np.array([[0.0, -z, y], [z, 0.0, -x], [-y, x, 0.0]])


def homogeneous(points: ArrayLike) -> NDArray[np.float64]:
    """Points (N, D) with a column of ones appended: (N, D + 1)."""
    X = np.asarray(points, dtype=float)
    return np.hstack([X, np.ones((X.shape[0], 1))])


def project(P: ArrayLike, points: ArrayLike, *, min_depth: float | None = None) -> NDArray[np.float64]:
    """Pixels (N, 2) of points (N, 3) under P (eq. 15).

    Without `min_depth`, NaN only where the point has no image (|w| < `AT_INFINITY`: P may have
    any scale and sign). With `min_depth`, NaN also where w <= min_depth: for a P whose w is the
    depth, the points behind (or too close to) the camera.
    """
    P = np.asarray(P, dtype=np.float64)
    X = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    x = X @ P[:, :3].T + P[:, 3]
    with np.errstate(divide="ignore", invalid="ignore"):
        uv: NDArray[np.float64] = x[:, :2] / x[:, 2:3]
    if min_depth is None:
        uv[np.abs(x[:, 2]) < AT_INFINITY] = np.nan
    else:
        uv[x[:, 2] <= min_depth] = np.nan
    return uv


def reprojection_errors(P: ArrayLike, world: ArrayLike, image: ArrayLike) -> NDArray[np.float64]:
    """||x_i - pi(P, X_i)|| for every point (pixels): world (N, 3), image (N, 2)."""
    residuals = project(P, world) - np.asarray(image, dtype=np.float64)
    errors: NDArray[np.float64] = np.linalg.norm(residuals, axis=1)
    return errors


def rodrigues(w: ArrayLike) -> NDArray[np.float64]:
    """The rotation exp([w]x) of an axis-angle vector w (3,) (Rodrigues' formula).

    Below an angle of 1e-12 rad it returns the first-order I + [w]x (exact to rounding there, and
    the identity for w = 0).
    """
    w = np.asarray(w, dtype=float).reshape(3)
    a = float(np.sqrt(w @ w))
    if a < 1e-12:
        return np.eye(3) + skew(w)
    kx = skew(w / a)
    R: NDArray[np.float64] = np.eye(3) + np.sin(a) * kx + (1.0 - np.cos(a)) * (kx @ kx)
    return R


def compose(K: ArrayLike, R: ArrayLike, t: ArrayLike) -> NDArray[np.float64]:
    """P = K [R | t]: one camera (K, R (3, 3), t (3,)) or a stack of C ((C, 3, 3), (C, 3, 3), (C, 3))."""
    Rt = np.concatenate([np.asarray(R, dtype=float), np.asarray(t, dtype=float)[..., None]], axis=-1)
    P: NDArray[np.float64] = np.asarray(K, dtype=float) @ Rt
    return P


@dataclass(frozen=True)
class Decomposition:
    """P = K [R | t] split into intrinsics K (K[2,2] = 1), rotation R (frame -> camera) and t.

    `center` is the optical centre in the calibration frame (C = -R^T t). `mirrored` is True when
    the image is a mirror image of a right-handed pinhole view (then K[0,0] < 0, R stays a proper
    rotation and points in front of the camera keep a positive depth).
    """

    K: NDArray[np.float64]
    R: NDArray[np.float64]
    t: NDArray[np.float64]
    center: NDArray[np.float64]
    mirrored: bool


def decompose(P: ArrayLike) -> Decomposition:
    """Split P into K [R | t] by an RQ decomposition of its left 3x3 block M.

    Convention: P's overall sign is such that points in front of the camera have w = (P X~)_3 > 0
    (`calibrate` fixes it so). Then P = lambda K [R | t] with lambda > 0, and since K's third row is
    (0, 0, 1), det M = lambda^3 det(K) det(R) has the sign of det(K): negative means a mirrored image
    (K[0,0] < 0 with R a proper rotation).

        M = K0 R0 (RQ),  D = diag(sign(diag K0)):  M = (K0 D)(D R0)     K0 D has a positive diagonal
        det(D R0) < 0  ->  K = K0 D F, R = F D R0 with F = diag(-1, 1, 1)   (mirrored)
        t = K^-1 p4,  K <- K / K[2,2],  C = -R^T t
    """
    P = np.asarray(P, dtype=float).reshape(3, 4)
    M = P[:, :3]
    if not np.all(np.isfinite(P)) or abs(np.linalg.det(M)) < 1e-12 * max(np.abs(M).max(), 1e-300) ** 3:
        raise CalibrationError("P has a singular left 3x3 block: it is not a finite camera")
    K, R = scipy.linalg.rq(M)
    D = np.diag(np.sign(np.diag(K)))
    K, R = K @ D, D @ R
    mirrored = bool(np.linalg.det(R) < 0)
    if mirrored:
        F = np.diag([-1.0, 1.0, 1.0])
        K, R = K @ F, F @ R
    t = np.linalg.solve(K, P[:, 3])
    K = K / K[2, 2]
    return Decomposition(K=K, R=R, t=t, center=-R.T @ t, mirrored=mirrored)


def quaternion_xyzw(R: ArrayLike) -> tuple[float, float, float, float]:
    """The unit quaternion (x, y, z, w) of a 3x3 rotation matrix R, as plain floats.

    The branch that divides by the largest of 1 + trace and the diagonal terms (Shepperd's method,
    numerically safe for every rotation; scipy's `Rotation.from_matrix(R).as_quat()` takes the same
    branch with the same formulas, so the two agree to the last bits and in sign):

        trace largest:  q = (R21 - R12, R02 - R20, R10 - R01, 1 + trace)
        R_ii largest:   q_i = 1 - trace + 2 R_ii, q_j = R_ji + R_ij, q_k = R_ki + R_ik,
                        w = R_kj - R_jk                           ((i, j, k) a cyclic order)

    then q / ||q||. About 3 us, against 40-50 us for scipy's for one matrix (the recorder's and the
    publishers' frames at 50 Hz)."""
    m = np.asarray(R, dtype=float).tolist()
    trace = m[0][0] + m[1][1] + m[2][2]
    decision = [m[0][0], m[1][1], m[2][2], trace]
    choice = max(range(4), key=decision.__getitem__)
    q = [0.0, 0.0, 0.0, 0.0]
    if choice == 3:
        q[0] = m[2][1] - m[1][2]
        q[1] = m[0][2] - m[2][0]
        q[2] = m[1][0] - m[0][1]
        q[3] = 1.0 + trace
    else:
        i = choice
        j = (i + 1) % 3
        k = (j + 1) % 3
        q[i] = 1.0 - trace + 2.0 * m[i][i]
        q[j] = m[j][i] + m[i][j]
        q[k] = m[k][i] + m[i][k]
        q[3] = m[k][j] - m[j][k]
    norm = math.sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3])
    return (q[0] / norm, q[1] / norm, q[2] / norm, q[3] / norm)
