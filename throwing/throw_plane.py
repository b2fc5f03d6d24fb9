"""The throw plane: the plane y = 0 of `link1`, with (x, z) = (horizontal distance from the joint-1
axis, height), m. Owns `xz`, the check of a point of that plane, and `turned`, a point of one
joint-1 angle's link1 in another's.

`link1` is `base` turned by q1 (joint 1's angle, the alignment angle that brings the target into
this plane) about the common z axis, through the common origin, for every arm the project loads
(`wiithrow.robot.arms`; tested in tests/robot/test_model.py). So heights are equal in both frames:
a landing height in `link1` is one in `base`. Points go between the frames with the arm model's one
transform, `ArmModel.to_frame(p, q, "link1")` (p_link1 = R_1^T (p_base - o_1)) and `from_frame`;
with o_1 on the z axis and R_1 = R_z(q1) that is a turn about z, which `turned` does without the
arm: a point p of link1 at joint-1 angle a is

    p' = R_z(a - b) p                                   in link1 at joint-1 angle b,

and in `base` (b = 0) R_z(a) p. A landing measured by the rig on link1 after a throw is in link1 at
the angle joint 1 had then; `turned` puts it in the throw's plane or in `base`.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from wiithrow.throwing.errors import ThrowingError


def xz(v: ArrayLike, what: str = "target") -> NDArray[np.float64]:
    """A finite (2,) array (x, z) in the throw plane, or a ThrowingError naming `what`."""
    a = np.asarray(v, dtype=np.float64)
    if a.shape != (2,) or not np.all(np.isfinite(a)):
        raise ThrowingError(f"{what} must be a finite (x, z) pair in link1 (m), got {v!r}")
    return a


def turned(points: ArrayLike, angle: float) -> NDArray[np.float64]:
    """`points` (3,) or (N, 3) turned by `angle` (rad) about the z axis: R_z(angle) p. A point of
    link1 at joint-1 angle a is `turned(p, a - b)` in link1 at angle b, `turned(p, a)` in base."""
    p = np.asarray(points, dtype=np.float64)
    c, s = np.cos(angle), np.sin(angle)
    out = p.copy()
    out[..., 0] = c * p[..., 0] - s * p[..., 1]
    out[..., 1] = s * p[..., 0] + c * p[..., 1]
    return out
