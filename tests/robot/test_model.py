"""ArmModel: forward kinematics against an independent DH implementation, Jacobians against finite
differences, frame velocities, batched positions, collision points, limit helpers, thread safety."""

from __future__ import annotations

import threading

import numpy as np
import pinocchio as pin
import pytest

from wiithrow.robot import RobotError, load_arm

# ----- an independent standard-DH implementation of the PA-10 (the DH table of docs/robot.md) --

DH_ALPHA = (-np.pi / 2, np.pi / 2, -np.pi / 2, np.pi / 2, -np.pi / 2, np.pi / 2, 0.0)
DH_D = (0.317, 0.0, 0.45, 0.0, 0.48, 0.0, 0.07)


def dh_frames(q):
    """Standard DH: T_i = Rz(theta_i) Tz(d_i) Tx(a_i) Rx(alpha_i), a = 0; returns the 8 frames 0..7."""
    T = np.eye(4)
    out = [T]
    for theta, d, alpha in zip(q, DH_D, DH_ALPHA):
        ct, st, ca, sa = np.cos(theta), np.sin(theta), np.cos(alpha), np.sin(alpha)
        A = np.array([[ct, -st * ca, st * sa, 0.0], [st, ct * ca, -ct * sa, 0.0], [0.0, sa, ca, d], [0, 0, 0, 1.0]])
        T = T @ A
        out.append(T)
    return out


@pytest.fixture(scope="module", params=["pa10", "panda", "ur5", "ur5e"])
def any_arm(request):
    return load_arm(request.param)


def random_q(arm, rng, n):
    return rng.uniform(arm.lower, arm.upper, size=(n, arm.nq))


def test_flange_at_the_documented_check_points(pa10):
    np.testing.assert_allclose(pa10.frame_position(np.zeros(7), "flange"), [0.0, 0.0, 1.317], atol=1e-12)
    q = np.array([0.3, 0.5, 0.0, 1.0, 0.0, 0.4, 0.0])
    p = pa10.frame_position(q, "flange")
    np.testing.assert_allclose(p, [0.7268, 0.2248, 0.7232], atol=5e-5)  # the 4 decimals docs/robot.md gives
    np.testing.assert_allclose(p, dh_frames(q)[7][:3, 3], atol=1e-6)


def test_flange_pose_matches_dh_for_random_q(pa10):
    rng = np.random.default_rng(1)
    for q in random_q(pa10, rng, 50):
        T = pa10.frame_placement(q, "flange")
        T_dh = dh_frames(q)[7]
        np.testing.assert_allclose(T[:3, 3], T_dh[:3, 3], atol=1e-6)
        np.testing.assert_allclose(T[:3, :3], T_dh[:3, :3], atol=1e-9)  # flange = DH frame 7


def test_wrist_and_elbow_points_match_dh(pa10):
    rng = np.random.default_rng(2)
    for q in random_q(pa10, rng, 20):
        F = dh_frames(q)
        pts = dict(zip(pa10.collision_point_names, pa10.collision_points(q)))
        np.testing.assert_allclose(pts["E1"], F[3][:3, 3], atol=1e-9)  # elbow: origin of DH frames 3, 4
        np.testing.assert_allclose(pts["W1"], F[5][:3, 3], atol=1e-9)  # wrist: origin of DH frames 5, 6


def test_positive_q2_moves_the_hand_forward_in_link1(pa10):
    for q1 in (0.0, 0.8, -2.0):
        q = np.array([q1, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0])
        T1 = pa10.frame_placement(q, "link1")
        p0 = np.linalg.inv(T1) @ np.append(pa10.frame_position(q, "flange"), 1)
        q[1] = 0.4
        p1 = np.linalg.inv(T1) @ np.append(pa10.frame_position(q, "flange"), 1)
        assert p1[0] - p0[0] > 0.3  # forward, along +x of link1
        assert abs(p1[1]) < 1e-12  # stays in the plane y = 0 of link1


def test_link1_rotates_with_q1_only(any_arm):
    rng = np.random.default_rng(3)
    for q in random_q(any_arm, rng, 20):
        T = any_arm.frame_placement(q, "link1")
        c, s = np.cos(q[0]), np.sin(q[0])
        np.testing.assert_allclose(T[:3, :3], [[c, -s, 0], [s, c, 0], [0, 0, 1]], atol=1e-12)
        np.testing.assert_allclose(T[:3, 3], 0.0, atol=1e-12)


def test_to_frame_and_from_frame_are_the_placement_and_its_inverse(any_arm):
    """p_frame = R^T (p_base - o) against the inverse 4x4 placement, for points, batches and frames."""
    rng = np.random.default_rng(5)
    for q in random_q(any_arm, rng, 10):
        for frame in ("link1", "flange", "ball"):
            T = any_arm.frame_placement(q, frame)
            P = rng.normal(size=(5, 3))
            expected = (np.linalg.inv(T) @ np.c_[P, np.ones(5)].T).T[:, :3]
            np.testing.assert_allclose(any_arm.to_frame(P, q, frame), expected, atol=1e-12)
            np.testing.assert_allclose(any_arm.from_frame(expected, q, frame), P, atol=1e-12)
            np.testing.assert_allclose(any_arm.to_frame(P[0], q, frame), expected[0], atol=1e-12)
        np.testing.assert_array_equal(any_arm.to_frame(P, q), any_arm.to_frame(P, q, "link1"))  # the default


def test_to_frame_keeps_shapes_and_nan_rows(pa10):
    q = pa10.home
    P = np.random.default_rng(6).normal(size=(2, 4, 3))
    P[1, 2] = np.nan
    out = pa10.to_frame(P, q)
    assert out.shape == (2, 4, 3) and pa10.to_frame(P[0, 0], q).shape == (3,)
    assert np.isnan(out[1, 2]).all() and np.isfinite(np.delete(out.reshape(-1, 3), 6, axis=0)).all()
    np.testing.assert_allclose(pa10.from_frame(out, q)[0], P[0], atol=1e-12)
    for bad in (np.zeros(2), np.zeros((4, 2)), 1.0):
        with pytest.raises(RobotError, match=r"\(3,\) or \(\.\.\., 3\)"):
            pa10.to_frame(bad, q)
    with pytest.raises(RobotError, match="no frame"):
        pa10.from_frame(P, q, "nowhere")


def test_link1_transform_is_the_turn_by_q1_for_every_arm(any_arm):
    """link1 = base turned by q1 about z through the base origin, for every arm the project loads: the
    throw plane's (x, z) are distance from the joint-1 axis and height whatever the other joints."""
    rng = np.random.default_rng(7)
    for q in random_q(any_arm, rng, 20):
        p = rng.normal(size=3)
        c, s = np.cos(q[0]), np.sin(q[0])
        np.testing.assert_allclose(
            any_arm.from_frame(p, q), [c * p[0] - s * p[1], s * p[0] + c * p[1], p[2]], atol=1e-12
        )
        q_other = q.copy()
        q_other[1:] = any_arm.home[1:]
        np.testing.assert_array_equal(any_arm.to_frame(p, q), any_arm.to_frame(p, q_other))


def test_planar_arm_stays_in_link1_plane(pa10):
    """With S3, E2 (and W2) at zero, the flange, marker and ball stay in the plane y = 0 of link1."""
    rng = np.random.default_rng(4)
    for q in random_q(pa10, rng, 20):
        q[[2, 4, 6]] = 0.0
        T1inv = np.linalg.inv(pa10.frame_placement(q, "link1"))
        for f in ("flange", "marker", "ball"):
            assert abs((T1inv @ np.append(pa10.frame_position(q, f), 1))[1]) < 1e-12


def test_base_is_the_world_frame(any_arm):
    np.testing.assert_allclose(any_arm.frame_placement(any_arm.home, "base"), np.eye(4), atol=1e-15)


def numeric_jacobian(arm, q, frame, h=1e-6):
    J = np.zeros((6, arm.nq))
    for i in range(arm.nq):
        dq = np.zeros(arm.nq)
        dq[i] = h
        Tp, Tm = arm.frame_placement(q + dq, frame), arm.frame_placement(q - dq, frame)
        J[:3, i] = (Tp[:3, 3] - Tm[:3, 3]) / (2 * h)
        J[3:, i] = pin.log3(Tp[:3, :3] @ Tm[:3, :3].T) / (2 * h)  # world-frame angular velocity
    return J


@pytest.mark.parametrize("frame", ["flange", "marker", "ball", "link1"])
def test_jacobian_matches_finite_differences(any_arm, frame):
    rng = np.random.default_rng(5)
    # stay 1e-3 inside the limits so that q +- h is valid
    for q in rng.uniform(any_arm.lower + 1e-3, any_arm.upper - 1e-3, size=(5, any_arm.nq)):
        J = any_arm.frame_jacobian(q, frame)
        assert J.shape == (6, any_arm.nq)
        np.testing.assert_allclose(J, numeric_jacobian(any_arm, q, frame), atol=1e-6)


def test_frame_velocity_is_the_time_derivative_of_position(any_arm):
    rng = np.random.default_rng(6)
    q = rng.uniform(any_arm.lower + 0.1, any_arm.upper - 0.1)
    dq = rng.normal(0, 1, any_arm.nq)
    h = 1e-6
    fd = (any_arm.frame_position(q + h * dq, "ball") - any_arm.frame_position(q - h * dq, "ball")) / (2 * h)
    np.testing.assert_allclose(any_arm.frame_velocity(q, dq, "ball"), fd, atol=1e-6)


def test_placement_and_jacobian_in_one_pass_agree(pa10):
    rng = np.random.default_rng(7)
    q = random_q(pa10, rng, 1)[0]
    T, J = pa10.frame_placement_and_jacobian(q, "ball")
    np.testing.assert_allclose(T, pa10.frame_placement(q, "ball"), atol=1e-15)
    np.testing.assert_allclose(J, pa10.frame_jacobian(q, "ball"), atol=1e-15)


def test_batched_positions_equal_single_ones(any_arm):
    rng = np.random.default_rng(8)
    Q = random_q(any_arm, rng, 30)
    P = any_arm.frame_positions(Q, "marker")
    assert P.shape == (30, 3)
    for q, p in zip(Q, P):
        np.testing.assert_allclose(p, any_arm.frame_position(q, "marker"), atol=1e-15)


def test_bad_shapes_and_frames_give_clear_errors(pa10):
    with pytest.raises(RobotError, match=r"shape \(7,\)"):
        pa10.frame_position(np.zeros(6), "flange")
    with pytest.raises(RobotError, match="finite"):
        pa10.frame_position(np.full(7, np.nan), "flange")
    with pytest.raises(RobotError, match="no frame 'hand'.*base, link1, flange, marker, ball"):
        pa10.frame_position(np.zeros(7), "hand")
    with pytest.raises(RobotError, match=r"\(T, 7\)"):
        pa10.frame_positions(np.zeros(7), "flange")


def test_collision_points(pa10):
    assert pa10.collision_point_names == ("S2", "E1", "W1", "flange", "marker", "ball")
    P = pa10.collision_points(pa10.home)
    assert P.shape == (6, 3)
    np.testing.assert_allclose(P[-1], pa10.frame_position(pa10.home, "ball"), atol=1e-15)
    assert P[:, 2].min() > 0.3  # home is well above the floor
    # arm folded down towards the floor: the points see it
    q = np.array([0.0, np.radians(90), 0.0, np.radians(30), 0.0, 0.0, 0.0])
    assert pa10.collision_points(q)[:, 2].min() < 0.0


def test_collision_points_of_other_arms(any_arm):
    P = any_arm.collision_points(any_arm.home)
    assert P.shape == (len(any_arm.collision_point_names), 3)
    assert P[:, 2].min() > 0.0
    np.testing.assert_allclose(P[-1], any_arm.frame_position(any_arm.home, "ball"), atol=1e-15)


def test_within_limits_and_clip(pa10):
    assert pa10.within_limits(pa10.home)
    q = pa10.home.copy()
    q[3] = pa10.upper[3] + 0.01
    assert not pa10.within_limits(q)
    c = pa10.clip(q)
    assert c[3] == pa10.upper[3] and pa10.within_limits(c)
    np.testing.assert_array_equal(np.delete(c, 3), np.delete(q, 3))


def test_home_is_inside_limits_and_read_only(any_arm):
    assert any_arm.within_limits(any_arm.home)
    with pytest.raises(ValueError):
        any_arm.home[0] = 1.0
    with pytest.raises(ValueError):
        any_arm.velocity_limit[0] = 1.0


def test_one_model_shared_by_threads_gives_correct_results(pa10):
    rng = np.random.default_rng(9)
    Q = random_q(pa10, rng, 200)
    expected = np.array([dh_frames(q)[7][:3, 3] for q in Q])
    errors = []

    def work(offset):
        for k in range(len(Q)):
            i = (k + offset) % len(Q)
            if np.max(np.abs(pa10.frame_position(Q[i], "flange") - expected[i])) > 1e-6:
                errors.append(i)

    threads = [threading.Thread(target=work, args=(o * 37,)) for o in range(4)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert errors == []
