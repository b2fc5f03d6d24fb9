"""A throw's error in 3D (`throwing.landing_error`): along / across the target's throw plane, its
height, and the total on the landing surface, whatever joint 1's angle; `throw_plane.turned`
takes a point of one joint-1 angle's link1 to another's and to base, as the arm model does."""

from __future__ import annotations

import math

import numpy as np
import pytest

from wiithrow.throwing.landing_error import UNKNOWN, LandingError, landing_error
from wiithrow.throwing.throw_plane import turned


def test_along_across_and_height_in_the_targets_throw_plane():
    psi = 0.4  # the target's azimuth in base
    target = turned(np.array([1.3, 0.0, 0.2]), psi)
    landing = turned(np.array([1.3 + 0.004, 0.015, 0.2 + 0.001]), psi)  # 4 mm beyond, 15 mm toward +y, 1 mm up
    error = landing_error(landing, target)
    assert error.along_m == pytest.approx(0.004, abs=1e-12) and error.across_m == pytest.approx(0.015, abs=1e-12)
    assert error.height_m == pytest.approx(0.001, abs=1e-12)
    assert error.total_m == pytest.approx(math.hypot(0.004, 0.015), abs=1e-12)
    # short of the target and toward -y: both signs turn
    short = landing_error(turned(np.array([1.29, -0.002, 0.2]), psi), target)
    assert short.along_m == pytest.approx(-0.01) and short.across_m == pytest.approx(-0.002)
    assert error.words("cm") == "1.6 cm (along +0.4, across +1.5)"
    assert error.words("mm") == "15.5 mm (along +4.0, across +15.0)"


def test_the_total_is_the_horizontal_distance_whatever_the_split():
    rng = np.random.default_rng(0)
    for _ in range(100):
        target = np.array([*rng.uniform(-2, 2, 2), rng.uniform(0, 0.5)])
        landing = target + rng.normal(0, 0.05, 3)
        assert landing_error(landing, target).total_m == pytest.approx(np.linalg.norm(landing[:2] - target[:2]))


def test_unknown_points_give_no_figure():
    assert not landing_error(np.full(3, np.nan), np.array([1.0, 0.0, 0.0])).known
    assert not landing_error(np.array([1.0, 0.0, 0.0]), None).known
    assert not landing_error(np.array([1.0, 0.0, 0.0]), np.zeros(3)).known  # a target on joint 1's axis
    assert UNKNOWN.to_dict()["total_m"] != UNKNOWN.to_dict()["total_m"]  # NaN: null once written
    assert isinstance(UNKNOWN, LandingError)


def test_turned_agrees_with_the_arm_models_link1(pa10):
    q = np.array(pa10.home, dtype=float)
    p_link1 = np.array([1.2, -0.03, 0.1])
    for q1 in (-0.7, 0.0, 0.35):
        q[0] = q1
        np.testing.assert_allclose(turned(p_link1, q1), pa10.from_frame(p_link1, q, "link1"), atol=1e-12)
        np.testing.assert_allclose(turned(turned(p_link1, q1), -q1), p_link1, atol=1e-12)
    # link1 at 0.3 rad seen from link1 at 0.2 rad: a turn by 0.1 rad
    np.testing.assert_allclose(turned(p_link1, 0.1), turned(turned(p_link1, 0.3), -0.2), atol=1e-12)
