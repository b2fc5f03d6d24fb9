"""The throw plane: `xz` accepts finite (x, z) pairs only. (The base <-> link1 transform is the arm
model's: tests/robot/test_model.py.)"""

from __future__ import annotations

import numpy as np
import pytest

from wiithrow.throwing.errors import ThrowingError
from wiithrow.throwing.throw_plane import xz


def test_xz_accepts_finite_pairs_only():
    np.testing.assert_array_equal(xz((1.5, 0.2)), [1.5, 0.2])
    with pytest.raises(ThrowingError, match=r"\(x, z\)"):
        xz((1.0, 2.0, 3.0))
    with pytest.raises(ThrowingError, match="landing"):
        xz((np.nan, 0.0), "landing")
