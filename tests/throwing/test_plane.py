"""The throw plane: link1 <-> base conversions agree with the arm's own link1 frame."""

from __future__ import annotations

import numpy as np
import pytest

from wiithrow.robot import load_arm
from wiithrow.throwing.errors import ThrowingError
from wiithrow.throwing.plane import base_to_link1, link1_to_base, plane_to_base, rz, xz


def test_link1_conversions_match_the_arm_frame():
    arm = load_arm("pa10")
    rng = np.random.default_rng(0)
    for _ in range(20):
        q = rng.uniform(arm.lower, arm.upper)
        T = arm.frame_placement(q, "link1")
        np.testing.assert_allclose(T[:3, :3], rz(q[0]), atol=1e-12)
        np.testing.assert_allclose(T[:3, 3], 0.0, atol=1e-12)
        p = rng.normal(size=3)
        np.testing.assert_allclose(link1_to_base(p, q[0]), T[:3, :3] @ p, atol=1e-12)
        np.testing.assert_allclose(base_to_link1(link1_to_base(p, q[0]), q[0]), p, atol=1e-12)


def test_plane_point_to_base_and_batches():
    p = plane_to_base((1.5, 0.2), np.pi / 2)
    np.testing.assert_allclose(p, [0.0, 1.5, 0.2], atol=1e-12)
    P = np.random.default_rng(1).normal(size=(5, 3))
    np.testing.assert_allclose(base_to_link1(P, 0.3), np.array([rz(0.3).T @ x for x in P]), atol=1e-12)
    with pytest.raises(ThrowingError, match=r"\(x, z\)"):
        xz((1.0, 2.0, 3.0))
    with pytest.raises(ThrowingError):
        xz((np.nan, 0.0))
