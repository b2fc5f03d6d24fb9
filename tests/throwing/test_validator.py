"""The independent validator: it rejects trajectories built to break each limit (and only that
limit), checks the floor with the arm's collision points, and is the only way to an executable
throw."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from wiithrow.robot import JointTrajectory, load_arm
from wiithrow.throwing.errors import TrajectoryRejected
from wiithrow.throwing.limiting import plan_throw
from wiithrow.throwing.operator import solve_throw
from wiithrow.throwing.validator import ValidatedThrow, collision_points_batch, require_valid, validate

DT = 0.001
POSE = np.array([0.0, 0.3, 0.0, 1.2, 0.0, 0.6, 0.0])  # elbow bent, hand forward-down, well above the floor


def jerk_trajectory(q0, joint, phases, rest_before=0.02, rest_after=0.02):
    """A trajectory at rest at q0 except `joint`, driven by piecewise-constant jerk `phases`
    [(duration s, jerk rad/s^3), ...]; samples every DT with exact q, dq, ddq (cubic polynomials)."""
    starts = [rest_before]
    for d, _ in phases:
        starts.append(starts[-1] + d)
    end = starts[-1] + rest_after
    t = np.arange(0, end + 1e-12, DT)
    # state at each phase start
    states = [(q0[joint], 0.0, 0.0)]
    for d, j in phases:
        p, v, a = states[-1]
        states.append((p + v * d + a * d**2 / 2 + j * d**3 / 6, v + a * d + j * d**2 / 2, a + j * d))
    Q = np.tile(q0, (t.size, 1)).astype(float)
    V = np.zeros_like(Q)
    A = np.zeros_like(Q)
    for k, tk in enumerate(t):
        i = np.searchsorted(starts, tk, side="right") - 1
        if i < 0:
            continue
        if i >= len(phases):
            p, v, a = states[-1]
            tau, j = tk - starts[-1], 0.0
        else:
            (p, v, a), j, tau = states[i], phases[i][1], tk - starts[i]
        Q[k, joint] = p + v * tau + a * tau**2 / 2 + j * tau**3 / 6
        V[k, joint] = v + a * tau + j * tau**2 / 2
        A[k, joint] = a + j * tau
    return JointTrajectory(t, Q, V, A)


def slow_move(q0, joint, delta, duration):
    """Move `joint` by `delta` in `duration` with a symmetric jerk profile: delta = 2 J tau^3."""
    tau = duration / 4
    J = delta / (2 * tau**3)
    return jerk_trajectory(q0, joint, [(tau, J), (tau, -J), (tau, -J), (tau, J)])


def found(report):
    return {(v.check, v.joint) for v in report.violations}


def plan_like(traj, k):
    return SimpleNamespace(
        trajectory=traj,
        release_time=traj.times[k],
        release=SimpleNamespace(q=traj.positions[k], dq=traj.velocities[k]),
        target=None,
    )


def test_a_clean_slow_move_passes(pa10):
    traj = slow_move(POSE, 3, 0.3, 1.0)
    report = validate(traj, pa10)
    assert report.ok, report.summary()
    assert report.min_clearance > 0.3
    assert isinstance(require_valid(plan_like(traj, 10), pa10), ValidatedThrow)


def test_position_violation(pa10):
    q0 = POSE.copy()
    q0[5] = 2.80  # W1, upper limit 2.8798 rad
    traj = slow_move(q0, 5, 0.2, 1.0)
    report = validate(traj, pa10)
    assert found(report) == {("position", "W1")}
    v = report.violations[0]
    assert v.bound == pytest.approx(pa10.upper[5]) and v.value > pa10.upper[5]
    with pytest.raises(TrajectoryRejected, match="position of W1"):
        require_valid(plan_like(traj, 0), pa10)


def test_velocity_violation(pa10):
    # E1 (2 rad/s, 14 rad/s^2, 180 rad/s^3): jerk 100 to 10 rad/s^2, hold, down: 2.2 rad/s
    up = [(0.1, 100.0), (0.12, 0.0), (0.1, -100.0)]
    traj = jerk_trajectory(POSE, 3, up + [(0.05, 0.0)] + [(d, -j) for d, j in up])
    assert np.abs(traj.velocities[:, 3]).max() == pytest.approx(2.2, abs=1e-6)
    report = validate(traj, pa10)
    assert found(report) == {("velocity", "E1"), ("velocity (first difference of positions)", "E1")}
    with pytest.raises(TrajectoryRejected, match="velocity of E1"):
        require_valid(plan_like(traj, 0), pa10)


def test_acceleration_violation(pa10):
    # S2 (1 rad/s, 7 rad/s^2, 90 rad/s^3): jerk 80 for 0.1 s: 8 rad/s^2, 0.8 rad/s
    traj = jerk_trajectory(POSE, 1, [(0.1, 80.0), (0.1, -80.0), (0.1, -80.0), (0.1, 80.0)])
    report = validate(traj, pa10)
    assert found(report) == {
        ("acceleration", "S2"),
        ("acceleration (difference of velocities)", "S2"),
        ("acceleration (second difference of positions)", "S2"),
    }
    assert np.abs(traj.accelerations[:, 1]).max() == pytest.approx(8.0, abs=1e-9)
    assert all(7.0 < abs(v.value) <= 8.0 + 1e-9 and v.bound == 7.0 for v in report.violations)


def test_jerk_violation(pa10):
    # S2: jerk 100 > 90 rad/s^3, acceleration only 5 rad/s^2
    traj = jerk_trajectory(POSE, 1, [(0.05, 100.0), (0.05, -100.0), (0.05, -100.0), (0.05, 100.0)])
    report = validate(traj, pa10)
    assert found(report) == {
        ("jerk (difference of accelerations)", "S2"),
        ("jerk (third difference of positions)", "S2"),
    }
    with pytest.raises(TrajectoryRejected, match="jerk"):
        require_valid(plan_like(traj, 0), pa10)


def test_floor_violation(pa10):
    # S2 0.3 -> 1.4 rad with the elbow bent: the wrist goes below z = 0 of base
    traj = slow_move(POSE, 1, 1.1, 3.0)
    report = validate(traj, pa10)
    names = {j for c, j in found(report) if c == "floor"}
    assert {c for c, _ in found(report)} == {"floor"}
    assert {"W1", "flange", "ball"} <= names
    assert report.min_clearance < 0.0
    with pytest.raises(TrajectoryRejected, match="floor"):
        require_valid(plan_like(traj, 0), pa10)
    # the margin is a link radius: 2.9 cm above the floor fails with the default 5 cm, passes with 2 cm
    near = slow_move(POSE, 1, 0.75, 3.0)
    assert 0.02 < validate(near, pa10).min_clearance < 0.05
    assert {c for c, _ in found(validate(near, pa10))} == {"floor"}
    assert validate(near, pa10, floor_margin=0.02).ok


def test_finite_differences_catch_inconsistent_samples(pa10):
    """Positions that move at 10 rad/s while the given velocities and accelerations say 'at rest'."""
    t = np.arange(0, 0.1, DT)
    Q = np.tile(POSE, (t.size, 1))
    Q[50:, 3] += 0.01  # a step of E1
    traj = JointTrajectory(t, Q, np.zeros_like(Q), np.zeros_like(Q))
    report = validate(traj, pa10)
    checks = {c for c, _ in found(report)}
    assert "velocity (first difference of positions)" in checks
    assert "acceleration (second difference of positions)" in checks
    assert "jerk (third difference of positions)" in checks
    assert "velocity" not in checks
    first = report.violations[0]
    assert first.time == pytest.approx(t[46], abs=0.004)


def test_motion_at_the_ends_and_a_wrong_release_are_refused(pa10):
    traj = slow_move(POSE, 3, 0.3, 1.0)
    cut = JointTrajectory(traj.times[:400], traj.positions[:400], traj.velocities[:400], traj.accelerations[:400])
    assert any(v.check.startswith("rest at the end") for v in validate(cut, pa10).violations)
    bad = plan_like(traj, 300)
    bad.release = SimpleNamespace(q=traj.positions[300] + 1e-6, dq=traj.velocities[300])
    with pytest.raises(TrajectoryRejected, match="release position"):
        require_valid(bad, pa10)
    off = plan_like(traj, 300)
    off.release_time = traj.times[300] + 0.0005
    with pytest.raises(TrajectoryRejected, match="release time is a sample"):
        require_valid(off, pa10)


def test_only_the_validator_makes_an_executable_throw(pa10):
    with pytest.raises(TypeError, match="require_valid"):
        ValidatedThrow(None, None)
    with pytest.raises(TrajectoryRejected, match="joints"):
        validate(JointTrajectory([0.0], np.zeros((1, 6)), np.zeros((1, 6)), np.zeros((1, 6))), pa10)


def test_batched_collision_points_equal_the_arm_model(pa10):
    p = solve_throw(pa10, (1.3, 0.2))
    tr = plan_throw(pa10, p, 0.2, q1=0.8).trajectory
    B = collision_points_batch(pa10, tr.positions)
    ref = np.array([pa10.collision_points(q) for q in tr.positions])
    np.testing.assert_allclose(B, ref, atol=1e-12)
    rng = np.random.default_rng(0)
    for name in ("panda", "ur5"):
        other = load_arm(name)
        Q = rng.uniform(other.lower, other.upper, (50, other.nq))
        np.testing.assert_allclose(
            collision_points_batch(other, Q), np.array([other.collision_points(q) for q in Q]), atol=1e-12
        )


def test_the_velocity_margin_holds_and_is_enforced(pa10):
    """The release check held 95 % of the velocity limits while the rest of a throw could reach
    100 %: the validator holds every sample to the one margin, VELOCITY_MARGIN."""
    from wiithrow.throwing.representation import VELOCITY_MARGIN

    assert VELOCITY_MARGIN == 0.95
    v_max = pa10.velocity_limit[3]
    # E1 up to 97 % of its limit and back: within the limit, above the margin
    tau = 0.2  # peak speed J tau^2, acceleration J tau = 9.7 rad/s^2, jerk 48.5 rad/s^3: within E1's limits
    J = 0.97 * v_max / tau**2
    fast = jerk_trajectory(POSE, 3, [(tau, J), (tau, -J), (tau, -J), (tau, J)])
    assert np.abs(fast.velocities[:, 3]).max() == pytest.approx(0.97 * v_max, rel=1e-6)
    assert validate(fast, pa10).ok  # within the limits themselves
    over = validate(fast, pa10, velocity_margin=VELOCITY_MARGIN)
    assert ("velocity", "E1") in found(over) and not over.ok
    with pytest.raises(TrajectoryRejected, match="velocity"):
        require_valid(plan_like(fast, 0), pa10)
