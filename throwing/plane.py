"""The throw plane: the plane y = 0 of `link1`, with (x, z) = (horizontal distance from the joint-1
axis, height).

`link1` is `base` turned by q1 (joint 1's angle, the alignment angle that brings the target into
this plane) about the common z axis, through the common origin:

    p_base = Rz(q1) p_link1,    p_link1 = Rz(q1)^T p_base,    Rz(q) = [[c, -s, 0], [s, c, 0], [0, 0, 1]]

Heights are equal in both frames, so a landing height in `link1` is one in `base`.
"""

from __future__ import annotations

import math

import numpy as np

from wiithrow.throwing.errors import ThrowingError


def rz(q1: float) -> np.ndarray:
    """3x3 rotation about z by q1 (rad): the orientation of `link1` in `base`."""
    c, s = math.cos(q1), math.sin(q1)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def xz(v, what: str = "target") -> np.ndarray:
    """A finite (2,) array (x, z) in the throw plane, or a ThrowingError naming `what`."""
    a = np.asarray(v, dtype=float)
    if a.shape != (2,) or not np.all(np.isfinite(a)):
        raise ThrowingError(f"{what} must be a finite (x, z) pair in link1 (m), got {v!r}")
    return a


def plane_to_base(p_xz, q1: float) -> np.ndarray:
    """(3,) point in `base` of the throw-plane point (x, z) of `link1` at joint-1 angle q1."""
    x, z = xz(p_xz, "point")
    return np.array([x * math.cos(q1), x * math.sin(q1), z])


def base_to_link1(p_base, q1: float) -> np.ndarray:
    """(..., 3) points (or vectors) in `base` expressed in `link1` at joint-1 angle q1."""
    return np.asarray(p_base, dtype=float) @ rz(q1)  # row-vector form of Rz^T p


def link1_to_base(p_link1, q1: float) -> np.ndarray:
    """(..., 3) points (or vectors) in `link1` expressed in `base` at joint-1 angle q1."""
    return np.asarray(p_link1, dtype=float) @ rz(q1).T
