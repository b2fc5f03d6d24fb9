"""The forward model: parameters -> release state -> landing, in base and link1."""

from __future__ import annotations

import numpy as np
import pytest

from wiithrow.throwing.ballistics import Ball, fly
from wiithrow.throwing.forward import predict_landing, release_of
from wiithrow.throwing.representation import ThrowParameters, ThrowShape

P = ThrowParameters([0.75, -0.35, -0.35], [0.45, 1.0, 3.5])


def test_release_is_the_ball_frame_at_the_release_pose(pa10):
    shape = ThrowShape()
    r = release_of(pa10, shape, P, 0.4)
    q = np.array([0.4, 0.75, 0, -0.35, 0, -0.35, 0])
    dq = np.array([0, 0.45, 0, 1.0, 0, 3.5, 0])
    np.testing.assert_allclose(r.position, pa10.frame_position(q, "ball"), atol=1e-12)
    np.testing.assert_allclose(r.velocity, pa10.frame_velocity(q, dq, "ball"), atol=1e-12)
    assert r.time == shape.acceleration_time


def test_landing_in_link1_does_not_depend_on_joint_1(pa10):
    shape = ThrowShape()
    ref = predict_landing(pa10, shape, P, 0.2, 0.0)
    assert abs(ref.link1[1]) < 1e-12  # a planar throw stays in the plane y = 0 of link1
    assert ref.link1[2] == pytest.approx(0.2)
    for q1 in (-1.0, 0.3, 2.5):
        land = predict_landing(pa10, shape, P, 0.2, q1)
        np.testing.assert_allclose(land.link1, ref.link1, atol=1e-12)
        np.testing.assert_allclose(
            land.landing.position[:2], land.link1[0] * np.array([np.cos(q1), np.sin(q1)]), atol=1e-12
        )
        r = release_of(pa10, shape, P, q1)
        np.testing.assert_allclose(land.landing.position, fly(r.position, r.velocity, 0.2).position, atol=1e-15)
    # drag off lands further
    assert predict_landing(pa10, shape, P, 0.2, drag=False).xz[0] > ref.xz[0] + 0.005
    assert predict_landing(pa10, shape, P, 0.2, ball=Ball(mass=0.5)).xz[0] > ref.xz[0]
