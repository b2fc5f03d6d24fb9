"""Ruckig planning and JointTrajectory: goals reached, limits never exceeded (sampled and by finite
differences), near-minimal durations, braking, interpolation, validation."""

from __future__ import annotations

import numpy as np
import pytest
import ruckig

from wiithrow.robot import JointTrajectory, LimitError, RobotError, check_trajectory, load_arm, plan_move, plan_stop

REL = 1e-9  # relative slack on limits for floating point


def assert_within_limits(traj, lim, jerk=True):
    """Every sample, and the finite differences of the samples, within the limits."""
    dt = np.diff(traj.times)[:, None]
    assert np.all(traj.positions >= lim.lower - 1e-12) and np.all(traj.positions <= lim.upper + 1e-12)
    assert np.all(np.abs(traj.velocities) <= lim.velocity * (1 + REL))
    assert np.all(np.abs(traj.accelerations) <= lim.acceleration * (1 + REL))
    # mean velocity / acceleration / jerk over each interval cannot exceed the bound of the instantaneous one
    assert np.all(np.abs(np.diff(traj.positions, axis=0) / dt) <= lim.velocity * (1 + 1e-7))
    assert np.all(np.abs(np.diff(traj.velocities, axis=0) / dt) <= lim.acceleration * (1 + 1e-7))
    if jerk:
        assert np.all(np.abs(np.diff(traj.accelerations, axis=0) / dt) <= lim.jerk * (1 + 1e-7))


def rest_to_rest_upper_bound(d, v, a, j):
    """Duration of a jerk-limited rest-to-rest profile cruising at v: an upper bound of the optimum."""
    return np.abs(d) / v + v / a + a / j


@pytest.mark.parametrize("name", ["pa10", "panda", "ur5"])
def test_random_moves_reach_goal_within_limits_near_minimal_time(name):
    arm = load_arm(name)
    lim = arm.limits
    rng = np.random.default_rng(20)
    for _ in range(10):
        q0, q1 = rng.uniform(arm.lower, arm.upper, size=(2, arm.nq))
        traj = plan_move(q0, q1, arm)
        np.testing.assert_allclose(traj.positions[0], q0, atol=1e-12)
        np.testing.assert_allclose(traj.positions[-1], q1, atol=1e-6)
        np.testing.assert_allclose(traj.velocities[-1], 0.0, atol=1e-6)
        assert_within_limits(traj, lim)
        np.testing.assert_allclose(np.diff(traj.times)[:-1], 0.001, atol=1e-12)
        assert 0 < traj.times[-1] - traj.times[-2] <= 0.001 + 1e-12
        assert traj.times[-1] == pytest.approx(traj.duration)
        d = q1 - q0
        lower = np.max(np.abs(d) / lim.velocity)  # no joint can be faster than at full speed throughout
        upper = np.max(rest_to_rest_upper_bound(d, lim.velocity, lim.acceleration, lim.jerk))
        assert lower <= traj.duration <= upper + 0.001, (lower, traj.duration, upper)


def test_long_move_takes_exactly_the_cruise_profile_time(pa10):
    q0, q1 = np.zeros(7), np.zeros(7)
    q0[0], q1[0] = -2.0, 2.0  # S1 over 4 rad at 1 rad/s: reaches its limits
    traj = plan_move(q0, q1, pa10)
    expected = rest_to_rest_upper_bound(4.0, 1.0, 7.0, 90.0)
    assert traj.duration == pytest.approx(expected, abs=0.0011)
    assert np.max(np.abs(traj.velocities[:, 0])) == pytest.approx(1.0, rel=1e-9)
    assert np.max(np.abs(traj.accelerations[:, 0])) == pytest.approx(7.0, rel=1e-9)


def test_move_from_a_moving_state_to_a_release_velocity(pa10):
    lim = pa10.limits
    v0 = np.array([0.2, -0.5, 0.0, 1.0, 0.0, 2.0, 0.0])
    a0 = np.array([0.0, 1.0, 0.0, -3.0, 0.0, 10.0, 0.0])
    v1 = np.array([0.0, 0.8, 0.0, 1.9, 0.0, 6.0, 0.0])
    traj = plan_move(pa10.home, pa10.home + 0.3, pa10, v_start=v0, a_start=a0, v_goal=v1)
    np.testing.assert_allclose(traj.velocities[0], v0, atol=1e-12)
    np.testing.assert_allclose(traj.accelerations[0], a0, atol=1e-12)
    np.testing.assert_allclose(traj.velocities[-1], v1, atol=1e-6)
    np.testing.assert_allclose(traj.positions[-1], pa10.home + 0.3, atol=1e-6)
    assert_within_limits(traj, lim)
    # the release state keeps its exact time: the last interval is shorter, the mean velocity over
    # it is still close to the release velocity
    h = traj.times[-1] - traj.times[-2]
    np.testing.assert_allclose((traj.positions[-1] - traj.positions[-2]) / h, v1, atol=np.max(lim.acceleration) * h)


def test_minimum_duration_is_honoured(pa10):
    traj = plan_move(pa10.home, pa10.home + 0.05, pa10, min_duration=2.0)
    assert traj.duration == pytest.approx(2.0, abs=0.0011)
    assert_within_limits(traj, pa10.limits)


def test_plan_move_refuses_bad_input_naming_the_joint(pa10):
    goal = pa10.home.copy()
    goal[3] = np.radians(140)  # E1 limit is 137 deg
    with pytest.raises(LimitError, match="joint E1") as e:
        plan_move(pa10.home, goal, pa10)
    assert e.value.joint == "E1"
    v = np.zeros(7)
    v[5] = 7.0  # W1 limit 6.2832 rad/s
    with pytest.raises(LimitError, match="joint W1 velocity 7.0000 exceeds its limit 6.2832"):
        plan_move(pa10.home, pa10.home, pa10, v_goal=v)
    with pytest.raises(RobotError, match=r"shape \(7,\)"):
        plan_move(pa10.home, np.zeros(6), pa10)
    with pytest.raises(RobotError, match="ArmModel or JointLimits"):
        plan_move(pa10.home, pa10.home, "pa10")
    with pytest.raises(RobotError, match="dt must be > 0"):
        plan_move(pa10.home, pa10.home, pa10, dt=0.0)


@pytest.mark.parametrize("t_stop", [0.05, 0.12, 0.3, 0.6])
def test_plan_stop_brakes_as_fast_as_the_limits_allow(pa10, t_stop):
    lim = pa10.limits
    goal = pa10.home + np.array([1.5, -1.0, 1.5, 0.5, -3.0, 1.5, 2.5])
    move = plan_move(pa10.home, goal, pa10)  # stop it while accelerating (0.05, 0.12 s) or cruising
    k = round(t_stop / move.dt)
    q0, v0, a0 = move.positions[k], move.velocities[k], move.accelerations[k]
    traj = plan_stop(q0, v0, a0, pa10)
    np.testing.assert_allclose(traj.positions[0], q0, atol=1e-12)
    np.testing.assert_allclose(traj.velocities[-1], 0.0, atol=1e-9)
    np.testing.assert_allclose(traj.accelerations[-1], 0.0, atol=1e-9)
    assert_within_limits(traj, lim)
    # cannot stop faster than |v|/a_max; a jerk-limited stop needs at most 3.5 a/j more
    lower = np.max(np.abs(v0) / lim.acceleration)
    upper = np.max(np.abs(v0) / lim.acceleration + 3.5 * lim.acceleration / lim.jerk)
    assert lower <= traj.duration <= upper + 0.001, (lower, traj.duration, upper)


def test_sample_interpolates_between_samples(pa10):
    q0, q1 = pa10.home, pa10.home + np.linspace(-0.5, 0.5, 7)
    traj = plan_move(q0, q1, pa10)
    # reference: Ruckig itself, at mid-sample times
    inp = ruckig.InputParameter(7)
    inp.current_position, inp.target_position = q0, q1
    inp.max_velocity, inp.max_acceleration, inp.max_jerk = pa10.velocity_limit, pa10.acceleration_limit, pa10.jerk_limit
    inp.min_position, inp.max_position = pa10.lower, pa10.upper
    ref = ruckig.Trajectory(7)
    ruckig.Ruckig(7).calculate(inp, ref)
    ts = np.arange(0.0005, traj.duration - 0.001, 0.0137)
    q, dq, ddq = traj.sample(ts)
    assert q.shape == (ts.size, 7)
    for t, qi, dqi, ddqi in zip(ts, q, dq, ddq):
        p, v, a = ref.at_time(t)
        np.testing.assert_allclose(qi, p, atol=1e-9)  # cubic Hermite: error ~ jerk dt^3
        np.testing.assert_allclose(dqi, v, atol=1e-3)  # linear: error ~ a_max dt / 2 ... jerk dt^2
        np.testing.assert_allclose(ddqi, a, atol=0.3)  # linear: error ~ jerk dt / 2
    # exact at samples, clamped outside
    q5, _, _ = traj.sample(traj.times[5])
    np.testing.assert_array_equal(q5, traj.positions[5])
    np.testing.assert_array_equal(traj.sample(-1.0)[0], traj.positions[0])
    np.testing.assert_array_equal(traj.sample(1e3)[0], traj.positions[-1])
    assert traj.dt == pytest.approx(0.001)


def test_check_trajectory_finds_violations(pa10):
    traj = plan_move(pa10.home, pa10.home + 0.4, pa10)
    check_trajectory(traj, pa10, check_jerk=True)
    fast = JointTrajectory(traj.times / 2, traj.positions, traj.velocities * 2, traj.accelerations * 4)
    with pytest.raises(LimitError, match="joint S1 velocity"):
        check_trajectory(fast, pa10)
    # sampled velocities say zero but the positions jump: the finite differences catch it
    P = traj.positions.copy()
    P[100:, 3] += 0.01
    sneaky = JointTrajectory(traj.times, P, np.zeros_like(P), np.zeros_like(P))
    with pytest.raises(LimitError, match="joint E1 finite-difference velocity .* at sample 99"):
        check_trajectory(sneaky, pa10)
    out = JointTrajectory(traj.times, traj.positions + 3.0, traj.velocities, traj.accelerations)
    with pytest.raises(LimitError, match="outside"):
        check_trajectory(out, pa10)


def test_joint_trajectory_validation():
    z = np.zeros((3, 2))
    with pytest.raises(RobotError, match="strictly increasing"):
        JointTrajectory([0.0, 0.1, 0.1], z, z, z)
    with pytest.raises(RobotError, match=r"shape \(3, nq\)"):
        JointTrajectory([0.0, 0.1, 0.2], np.zeros((2, 2)), z, z)
    with pytest.raises(RobotError, match="finite"):
        JointTrajectory([0.0, 0.1, 0.2], np.full((3, 2), np.nan), z, z)
    one = JointTrajectory([0.0], np.ones((1, 2)), np.zeros((1, 2)), np.zeros((1, 2)))
    assert one.duration == 0.0 and one.dt == 0.0
    np.testing.assert_array_equal(one.sample(0.3)[0], [1.0, 1.0])
    t = JointTrajectory([0.0, 0.1, 0.2], z, z, z)
    with pytest.raises(ValueError):
        t.positions[0, 0] = 1.0  # read-only
