"""Ruckig limiting: the planned trajectory reaches the release state exactly, follows the
reference, is sampled at 1 ms, stays within the limits, and the simulated arm plays it exactly."""

from __future__ import annotations

import numpy as np
import pytest

from wiithrow.robot import LimitError, SimulatedArm, check_trajectory
from wiithrow.throwing.errors import InfeasibleThrowError
from wiithrow.throwing.limiting import _evaluate, _planner, _Segment, plan_throw
from wiithrow.throwing.operator import solve_throw
from wiithrow.throwing.release import release_state
from wiithrow.throwing.representation import ThrowParameters, ThrowShape

SHAPE = ThrowShape()
TARGETS = [(1.0, 0.0), (1.6, 0.0), (1.0, 0.4), (1.6, 0.4), (1.3, 0.2), (1.45, 0.1)]


@pytest.fixture(scope="module")
def throws(pa10):
    return [(t, solve_throw(pa10, t)) for t in TARGETS]


def test_release_state_is_reached_exactly(pa10, throws):
    for (x, z), p in throws:
        for q1 in (0.0, -0.7):
            plan = plan_throw(pa10, p, z, q1=q1, target=(x, z))
            tr = plan.trajectory
            # every segment took exactly its knot interval
            assert plan.release_time == pytest.approx(SHAPE.acceleration_time, abs=1e-12)
            k = plan.release_index
            assert tr.times[k] == plan.release_time
            q_int = SHAPE.full_q(pa10, p.q_release, q1)
            dq_int = SHAPE.full_dq(pa10, p.dq_release)
            assert np.max(np.abs(tr.positions[k] - q_int)) < 1e-9
            assert np.max(np.abs(tr.velocities[k] - dq_int)) < 1e-9
            assert np.max(np.abs(tr.accelerations[k])) < 1e-9
            # the ball's state from the sample equals the intended release (position and velocity, base)
            r = release_state(pa10, tr.positions[k], tr.velocities[k])
            np.testing.assert_allclose(r.position, plan.release.position, atol=1e-9)
            np.testing.assert_allclose(r.velocity, plan.release.velocity, atol=1e-8)
            # and the predicted landing is the target (the operator's throw, noise-free)
            assert abs(plan.predicted.xz[0] - x) < 1e-6 and abs(plan.predicted.link1[1]) < 1e-9


def test_trajectory_layout_and_limits(pa10, throws):
    for (_x, z), p in throws:
        plan = plan_throw(pa10, p, z, q1=0.5)
        tr = plan.trajectory
        h = np.diff(tr.times)
        assert np.all((h >= 0.0002 - 1e-12) & (h <= 0.0012 + 1e-12))
        assert np.mean(np.abs(h - 0.001) < 1e-9) > 0.99  # all but the intervals next to the release and the end
        assert tr.times[0] == 0.0
        np.testing.assert_array_equal(tr.positions[:, 0], 0.5)  # joint 1 holds the alignment angle
        np.testing.assert_array_equal(tr.positions[:, [2, 4, 6]], 0.0)  # S3, E2, W2 held
        np.testing.assert_array_equal(tr.velocities[:, [0, 2, 4, 6]], 0.0)
        np.testing.assert_allclose(tr.positions[0], SHAPE.full_q(pa10, SHAPE.windup(p), 0.5), atol=1e-15)
        np.testing.assert_allclose(tr.velocities[[0, -1]], 0.0, atol=1e-12)
        np.testing.assert_allclose(tr.accelerations[[0, -1]], 0.0, atol=1e-12)
        check_trajectory(tr, pa10, tol=1e-9, check_jerk=True)  # the robot package's own check agrees
        assert tr.duration < 0.7  # 0.32 s acceleration + a follow-through of at most 0.3 s


def test_trajectory_follows_the_reference(pa10, throws):
    for (_x, z), p in throws:
        plan = plan_throw(pa10, p, z)
        tr = plan.trajectory
        acc = tr.times <= plan.release_time
        q, dq, _ = SHAPE.reference(p, tr.times[acc])
        mov = [1, 3, 5]
        assert np.max(np.abs(tr.positions[acc][:, mov] - q)) < 1e-3  # rad; measured 2e-4
        assert np.max(np.abs(tr.velocities[acc][:, mov] - dq)) < 0.03  # rad/s; measured 0.018 (W1)


def test_closed_form_sampling_equals_ruckig_at_time(pa10):
    pl = _planner(3)
    vmax, amax, jmax = pa10.velocity_limit[[1, 3, 5]], pa10.acceleration_limit[[1, 3, 5]], pa10.jerk_limit[[1, 3, 5]]
    lo, hi = pa10.lower[[1, 3, 5]], pa10.upper[[1, 3, 5]]
    s0 = (np.array([0.6, -0.5, -1.2]), np.array([0.1, 0.3, 1.0]), np.array([1.0, 2.0, 10.0]))
    s1 = (np.array([0.65, -0.45, -1.0]), np.array([0.3, 0.8, 3.0]), np.array([2.0, 4.0, 20.0]))
    move = _Segment(pl.move(s0, s1, vmax, amax, jmax, lo, hi, 0.04, "test"), 0.0)
    stop = _Segment(pl.stop(s1, vmax, amax, jmax), move.duration)
    assert move.table is not None and stop.table is not None
    t = np.sort(np.random.default_rng(0).uniform(0, move.duration + stop.duration + 0.05, 500))
    P, V, A = _evaluate([move, stop], t)
    for k, tk in enumerate(t):
        seg = move if tk < move.duration else stop
        p, v, a = seg.traj.at_time(tk - seg.start)
        np.testing.assert_allclose(P[k], p, atol=1e-12)
        np.testing.assert_allclose(V[k], v, atol=1e-12)
        np.testing.assert_allclose(A[k], a, atol=1e-10)
    # a start above the velocity limit makes Ruckig brake first: that segment is sampled with at_time
    fast = (s0[0], np.array([1.2, 0.3, 1.0]), np.zeros(3))
    braking = _Segment(pl.move(fast, s1, vmax, amax, jmax, lo, hi, None, "test"), 0.0)
    assert braking.table is None
    t = np.linspace(0, braking.duration, 50)
    P, V, A = braking.evaluate(t)
    for k, tk in enumerate(t):
        np.testing.assert_allclose(P[k], braking.traj.at_time(tk)[0], atol=1e-15)


def test_prelude_from_a_start_pose(pa10, throws):
    (_x, z), p = throws[4]
    plan = plan_throw(pa10, p, z, q1=0.3, q_start=pa10.home)
    tr = plan.trajectory
    np.testing.assert_allclose(tr.positions[0], pa10.home)
    k = plan.release_index
    np.testing.assert_allclose(tr.positions[k], SHAPE.full_q(pa10, p.q_release, 0.3), atol=1e-9)
    assert plan.release_time > SHAPE.acceleration_time + 0.5  # the prelude takes time
    check_trajectory(tr, pa10, tol=1e-9, check_jerk=True)


class StepClock:
    def __init__(self) -> None:
        self.t = 0.0

    def now(self) -> float:
        return self.t

    def sleep(self, s: float) -> None:
        self.t += s


def test_the_simulated_arm_plays_it_exactly(pa10, throws):
    (_x, z), p = throws[3]
    plan = plan_throw(pa10, p, z, q1=0.2)
    tr = plan.trajectory
    clock = StepClock()
    sim = SimulatedArm(pa10, clock, q0=tr.positions[0])
    sim.command_trajectory(tr)
    clock.t = plan.release_time
    s = sim.ideal_state()
    np.testing.assert_allclose(s.q, plan.release.q, atol=1e-9)
    np.testing.assert_allclose(s.dq, plan.release.dq, atol=1e-3)  # the servo's dq is the mean over the last ms
    assert sim.wait_until_idle(2.0)
    np.testing.assert_allclose(sim.ideal_state().q, tr.positions[-1], atol=1e-9)
    assert sim.saturated_steps == 0 and sim.position_clamped_steps == 0


def test_infeasible_parameters_are_refused(pa10):
    with pytest.raises(InfeasibleThrowError, match="W1"):
        plan_throw(pa10, ThrowParameters([0.7, -0.4, -0.3], [0.5, 1.0, 6.1]), 0.2)
    # why the margin matters: Ruckig refuses (does not clip) a target velocity above the limit
    pl = _planner(1)
    z = np.zeros(1)
    with pytest.raises(LimitError, match="Ruckig refused"):
        pl.move((z, z, z), (np.ones(1), np.array([2.5]), z), [2.0], [14.0], [180.0], [-3.0], [3.0], 0.3, "test")
