"""The mono method the paper compares against: one camera, two IR beacons a known distance apart.

This is how the Wii console itself estimates the remote's distance to the sensor bar. With the
camera's intrinsics K, the beacons' pixels a and b map to normalised image coordinates
n = K^-1 [u, v, 1]^T. If the beacon pair lies in a plane parallel to the image plane, both are at
the same depth Z and similar triangles give

    ||n_a - n_b|| = D / Z      =>      Z = D / ||n_a - n_b||                 (D: beacon distance)

and their midpoint is at X_cam = Z * (n_a + n_b) / 2 in camera coordinates (for f = fx = fy this
is the familiar Z = f D / d_px). When the beacon line is turned by an angle theta out of that plane
its image shrinks by about cos(theta), so the depth comes out too large by about 1 / cos(theta):
the method's systematic error, which the stereo rig does not have (paper Fig. 6).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from wiithrow.vision.errors import VisionError
from wiithrow.vision.geometry import homogeneous


def mono_position(
    pixels_a: ArrayLike,
    pixels_b: ArrayLike,
    beacon_distance: float,
    K: ArrayLike,
    R: ArrayLike | None = None,
    t: ArrayLike | None = None,
) -> NDArray[np.float64]:
    """Midpoint (N, 3) of two beacons `beacon_distance` metres apart, from one camera.

    pixels_a, pixels_b: (N, 2) pixels of the two beacons (NaN where not seen: the result is NaN).
    K: the camera's 3x3 intrinsics. R, t (optional): the camera's pose, x_cam = R X + t; when
    given the result is in the frame X lives in, otherwise in camera coordinates.
    """
    if not beacon_distance > 0:
        raise VisionError(f"the beacon distance must be positive, got {beacon_distance}")
    a = np.asarray(pixels_a, dtype=float).reshape(-1, 2)
    b = np.asarray(pixels_b, dtype=float).reshape(-1, 2)
    if a.shape != b.shape:
        raise VisionError(f"beacon pixel arrays differ in shape: {a.shape} and {b.shape}")
    K_inv = np.linalg.inv(np.asarray(K, dtype=float).reshape(3, 3))
    na = homogeneous(a) @ K_inv.T
    nb = homogeneous(b) @ K_inv.T
    na, nb = na / na[:, 2:3], nb / nb[:, 2:3]
    with np.errstate(divide="ignore", invalid="ignore"):
        depth = beacon_distance / np.linalg.norm(na[:, :2] - nb[:, :2], axis=1)
    depth[~np.isfinite(depth)] = np.nan
    X_cam: NDArray[np.float64] = depth[:, None] * (na + nb) / 2.0
    if R is None:
        return X_cam
    R = np.asarray(R, dtype=np.float64).reshape(3, 3)
    t = np.zeros(3) if t is None else np.asarray(t, dtype=np.float64).reshape(3)
    X: NDArray[np.float64] = (X_cam - t) @ R  # X = R^T (x_cam - t)
    return X
