"""The throw plane: the plane y = 0 of `link1`, with (x, z) = (horizontal distance from the joint-1
axis, height), m. Owns `xz`, the check of a point of that plane.

`link1` is `base` turned by q1 (joint 1's angle, the alignment angle that brings the target into
this plane) about the common z axis, through the common origin, for every arm the project loads
(`wiithrow.robot.arms`; tested in tests/robot/test_model.py). So heights are equal in both frames:
a landing height in `link1` is one in `base`. Points go between the frames with the arm model's one
transform, `ArmModel.to_frame(p, q, "link1")` (p_link1 = R_1^T (p_base - o_1)) and `from_frame`.
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
