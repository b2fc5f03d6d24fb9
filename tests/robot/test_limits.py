"""JointLimits and the robot exceptions: checks name the offending joint, errors carry their data."""

from __future__ import annotations

import numpy as np
import pytest

from wiithrow.robot import JointLimits, LimitError, RobotError, UnreachableError


def limits():
    return JointLimits(("a", "b"), [-1, -2], [1, 2], [1, 3], [10, 30], [100, 300])


def test_exception_hierarchy():
    assert issubclass(RobotError, ValueError)
    assert issubclass(LimitError, RobotError) and issubclass(UnreachableError, RobotError)


def test_check_position_names_the_joint():
    lim = limits()
    np.testing.assert_array_equal(lim.check_position([0.5, -1.5]), [0.5, -1.5])
    with pytest.raises(LimitError, match=r"joint b = -2\.5000 rad .* outside its limits \[-2\.0000, 2\.0000\]") as e:
        lim.check_position([0.5, -2.5])
    assert e.value.joint == "b"
    with pytest.raises(RobotError, match=r"shape \(2,\)"):
        lim.check_position([0.0, 0.0, 0.0])


def test_check_bound_and_within_and_clip():
    lim = limits()
    lim.check_bound([[0.5, 2.9], [-1.0, -3.0]], lim.velocity, "velocity", "v")
    with pytest.raises(LimitError, match="joint a velocity 1.1000 at sample 1 exceeds its limit 1.0000"):
        lim.check_bound([[0.5, 2.9], [-1.1, 0.0]], lim.velocity, "velocity", "v")
    assert lim.within([1.0, 2.0]) and not lim.within([1.01, 0.0])
    np.testing.assert_array_equal(lim.clip([5.0, -5.0]), [1.0, -2.0])


def test_scaled_limits():
    s = limits().scaled(velocity=0.5, acceleration=0.25)
    np.testing.assert_array_equal(s.velocity, [0.5, 1.5])
    np.testing.assert_array_equal(s.acceleration, [2.5, 7.5])
    np.testing.assert_array_equal(s.jerk, [100, 300])
    with pytest.raises(RobotError, match="velocity scale"):
        limits().scaled(velocity=1.5)


def test_invalid_limits_are_refused():
    with pytest.raises(RobotError, match="lower position limit"):
        JointLimits(("a",), [1], [0], [1], [1], [1])
    with pytest.raises(RobotError, match="jerk limit must be > 0"):
        JointLimits(("a",), [0], [1], [1], [1], [0])
    with pytest.raises(RobotError, match="finite"):
        JointLimits(("a",), [0], [np.inf], [1], [1], [1])


def test_unreachable_error_carries_target_and_distance():
    e = UnreachableError(np.array([3.0, 0.0, 0.5]), 1.85, "ball", np.zeros(7))
    assert e.distance == 1.85 and e.frame == "ball"
    np.testing.assert_array_equal(e.target, [3.0, 0.0, 0.5])
    assert "1.8500 m" in str(e) and "(3.0000, 0.0000, 0.5000)" in str(e)
