"""`quaternion_xyzw`: a rotation matrix's unit quaternion in plain floats, equal to scipy's."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from wiithrow.vision.geometry import quaternion_xyzw, rodrigues


def test_equals_scipys_quaternion_to_the_bit_on_random_rotations():
    matrices = Rotation.random(20_000, random_state=7).as_matrix()
    ours = np.array([quaternion_xyzw(R) for R in matrices])
    np.testing.assert_array_equal(ours, Rotation.from_matrix(matrices).as_quat())


@pytest.mark.parametrize(
    "w",
    [(0.0, 0.0, 0.0), (np.pi, 0.0, 0.0), (0.0, np.pi, 0.0), (0.0, 0.0, np.pi), (1e-9, 0.0, 0.0), (2.0, -1.0, 0.5)],
)
def test_every_branch_gives_the_rotation_back(w):
    """The identity, the half turns about each axis (each diagonal term largest) and a tiny angle:
    the quaternion's own rotation matrix is the one given, to 1e-12."""
    R = rodrigues(w)
    x, y, z, qw = quaternion_xyzw(R)
    assert abs(np.linalg.norm([x, y, z, qw]) - 1.0) < 1e-15
    np.testing.assert_allclose(Rotation.from_quat([x, y, z, qw]).as_matrix(), R, atol=1e-12)
