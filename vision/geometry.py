"""The projective geometry every part of vision shares, each formula once.

A camera maps a point X = (x, y, z) to the pixel (u, v) by its 3x4 projection matrix P, with
X~ = [X; 1] the point in homogeneous coordinates:

    (a, b, w) = P X~,        u = a / w,        v = b / w                                (paper eq. 15)

w is the point's depth when P is scaled so that ||P[2, :3]|| = 1 with the points in front of the
camera at w > 0 (as `calibrate` and `WiimoteCamera` make it); for an arbitrary P (any scale, any
sign) only w = 0, a point in the camera's focal plane, has no image.

Rotations are parametrised by axis-angle vectors w (the angle ||w|| about the axis w / ||w||):

    R = exp([w]x) = I + sin(a) [k]x + (1 - cos(a)) [k]x^2,     a = ||w||,  k = w / a    (Rodrigues)

with [v]x the cross-product matrix, [v]x y = v x y.

The compiled kernels (`wiithrow.vision.kernels`) compute the same projection point by point in
`kernels.project_point`.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

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
    P = np.asarray(P, dtype=float)
    X = np.asarray(points, dtype=float).reshape(-1, 3)
    x = X @ P[:, :3].T + P[:, 3]
    with np.errstate(divide="ignore", invalid="ignore"):
        uv = x[:, :2] / x[:, 2:3]
    if min_depth is None:
        uv[np.abs(x[:, 2]) < AT_INFINITY] = np.nan
    else:
        uv[x[:, 2] <= min_depth] = np.nan
    return uv


def reprojection_errors(P: ArrayLike, world: ArrayLike, image: ArrayLike) -> NDArray[np.float64]:
    """||x_i - pi(P, X_i)|| for every point (pixels): world (N, 3), image (N, 2)."""
    residuals: NDArray[np.float64] = project(P, world) - np.asarray(image, dtype=float)
    return np.linalg.norm(residuals, axis=1)


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
    return np.eye(3) + np.sin(a) * kx + (1.0 - np.cos(a)) * (kx @ kx)
