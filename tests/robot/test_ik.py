"""Inverse kinematics: random reachable targets, unreachable ones, locked joints, facing, other arms."""

from __future__ import annotations

import numpy as np
import pytest

from wiithrow.robot import RobotError, UnreachableError, load_arm, solve_position

PA10_SHOULDER = np.array([0.0, 0.0, 0.317])
PA10_REACH_BALL = 0.45 + 0.48 + 0.07 + 0.15  # shoulder to ball frame, stretched


@pytest.mark.parametrize("frame", ["flange", "marker", "ball"])
def test_random_reachable_targets_pa10(pa10, frame):
    rng = np.random.default_rng(10)
    for _ in range(40):
        target = pa10.frame_position(rng.uniform(pa10.lower, pa10.upper), frame)
        q = solve_position(pa10, frame, target, pa10.home, tol=1e-4)
        assert np.linalg.norm(pa10.frame_position(q, frame) - target) < 1e-4
        assert pa10.within_limits(q, tol=0.0)


@pytest.mark.parametrize("name", ["panda", "ur5"])
def test_other_arms_solve_too(name):
    arm = load_arm(name)
    rng = np.random.default_rng(11)
    for _ in range(20):
        target = arm.frame_position(rng.uniform(arm.lower, arm.upper), "ball")
        q = solve_position(arm, "ball", target, arm.home)
        assert np.linalg.norm(arm.frame_position(q, "ball") - target) < 1e-4
        assert arm.within_limits(q, tol=0.0)


def test_tight_tolerance(pa10):
    target = np.array([0.6, -0.2, 0.4])
    q = solve_position(pa10, "ball", target, pa10.home, tol=1e-9)
    assert np.linalg.norm(pa10.frame_position(q, "ball") - target) < 1e-9


def test_unreachable_target_reports_how_close_it_got(pa10):
    target = np.array([3.0, 0.0, 0.5])
    with pytest.raises(UnreachableError) as e:
        solve_position(pa10, "ball", target, pa10.home)
    lower_bound = np.linalg.norm(target - PA10_SHOULDER) - PA10_REACH_BALL  # no configuration does better
    assert lower_bound - 1e-9 <= e.value.distance < lower_bound + 0.02
    np.testing.assert_array_equal(e.value.target, target)
    assert e.value.frame == "ball"
    assert np.linalg.norm(pa10.frame_position(e.value.q_best, "ball") - target) == pytest.approx(e.value.distance)
    assert f"{e.value.distance:.4f} m" in str(e.value)


def test_locked_joints_keep_their_values_and_the_arm_stays_in_its_plane(pa10):
    q0 = pa10.home.copy()
    q0[0] = 0.4  # S1 locked at 0.4: the reachable plane is turned by 0.4 about z
    target_l1 = np.array([0.8, 0.0, 0.3])  # in link1: distance 0.8 m, height 0.3 m
    c, s = np.cos(0.4), np.sin(0.4)
    target = np.array([c * target_l1[0], s * target_l1[0], target_l1[2]])
    locked = ["S1", "S3", "E2", "W2"]
    q = solve_position(pa10, "ball", target, q0, locked_joints=locked)
    assert np.linalg.norm(pa10.frame_position(q, "ball") - target) < 1e-4
    for name in locked:
        i = pa10.joint_names.index(name)
        assert q[i] == q0[i]
    # a target out of that plane cannot be reached with those joints locked: distance = offset
    with pytest.raises(UnreachableError) as e:
        solve_position(pa10, "ball", [0.8, 0.1, 0.3], np.zeros(7), locked_joints=[0, 2, 4, 6])
    assert e.value.distance == pytest.approx(0.1, abs=1e-3)


def test_face_direction_turns_the_marker_towards_the_cameras(pa10):
    camera = np.array([0.0, 0.0, 0.35])  # the rig on link1, near shoulder height
    for target in ([0.55, 0.1, 0.45], [0.6, -0.15, 0.3], [0.5, 0.0, 0.6]):
        toward_camera = camera - target
        toward_camera /= np.linalg.norm(toward_camera)
        q = solve_position(pa10, "marker", target, pa10.home, face_direction=toward_camera)
        T = pa10.frame_placement(q, "marker")
        assert np.linalg.norm(T[:3, 3] - target) < 1e-4
        assert pa10.within_limits(q, tol=0.0)
        angle = np.degrees(np.arccos(np.clip(T[:3, 2] @ toward_camera, -1, 1)))
        assert angle < 2.0, angle
        # without the hint the LED points elsewhere
        q_free = solve_position(pa10, "marker", target, pa10.home)
        z_free = pa10.frame_placement(q_free, "marker")[:3, 2]
        assert np.degrees(np.arccos(np.clip(z_free @ toward_camera, -1, 1))) > 30.0


def test_face_direction_is_best_effort_when_the_position_forbids_it(pa10):
    """Far forward, the hand cannot fold back towards the base: the position still wins."""
    target = np.array([0.8, 0.2, 0.2])
    q = solve_position(pa10, "marker", target, pa10.home, face_direction=[-1.0, 0.0, 0.0])
    assert np.linalg.norm(pa10.frame_position(q, "marker") - target) < 1e-4


def test_deterministic(pa10):
    target = [0.2, 0.7, 0.2]
    a = solve_position(pa10, "ball", target, np.zeros(7))
    b = solve_position(pa10, "ball", target, np.zeros(7))
    np.testing.assert_array_equal(a, b)
    c = solve_position(pa10, "ball", target, np.zeros(7), rng=np.random.default_rng(0))
    np.testing.assert_array_equal(a, c)


def test_bad_arguments(pa10):
    with pytest.raises(RobotError, match="target_xyz"):
        solve_position(pa10, "ball", [1.0, 2.0], pa10.home)
    with pytest.raises(RobotError, match="no frame 'hand'"):
        solve_position(pa10, "hand", [0.5, 0, 0.5], pa10.home)
    with pytest.raises(RobotError, match="unknown joint 'X1'"):
        solve_position(pa10, "ball", [0.5, 0, 0.5], pa10.home, locked_joints=["X1"])
    with pytest.raises(RobotError, match="every joint is locked"):
        solve_position(pa10, "ball", [0.5, 0, 0.5], pa10.home, locked_joints=range(7))
    with pytest.raises(RobotError, match="face_direction"):
        solve_position(pa10, "ball", [0.5, 0, 0.5], pa10.home, face_direction=[0, 0, 0])
