"""SimulatedArm on a manual clock: moves reach their goal, stops come to rest in time, velocity and
acceleration limits hold at every step (even for commands that ask for more), tracking error
statistics, replanning while moving, threads."""

from __future__ import annotations

import threading
import time

import numpy as np
import pytest

from tests.helpers.per_step_arm import PerStepArm
from wiithrow.robot import Arm, JointState, JointTrajectory, LimitError, RobotError, SimulatedArm, plan_move


class ManualClock:
    """Time moves only through advance() or sleep(); thread-safe."""

    def __init__(self, t: float = 0.0) -> None:
        self._t = t
        self._lock = threading.Lock()

    def now(self) -> float:
        with self._lock:
            return self._t

    def sleep(self, seconds: float) -> None:
        self.advance(max(0.0, seconds))

    def advance(self, seconds: float) -> None:
        with self._lock:
            self._t += seconds


def run(sim, clock, seconds, dt=0.001):
    """Advance `seconds` in steps of dt, reading the state at each; returns the states."""
    states = []
    for _ in range(round(seconds / dt)):
        clock.advance(dt)
        states.append(sim.state())
    return states


def assert_states_within_limits(states, lim, dt=0.001):
    t = np.array([s.t for s in states])
    V = np.array([s.dq for s in states])
    Q = np.array([s.q for s in states])
    np.testing.assert_allclose(np.diff(t), dt, atol=1e-9)  # one state per servo step
    assert np.all(np.abs(V) <= lim.velocity * (1 + 1e-9))
    A = np.diff(V, axis=0) / dt
    assert np.all(np.abs(A) <= lim.acceleration * (1 + 1e-6)), np.max(np.abs(A) / lim.acceleration)
    assert np.all(lim.lower - 1e-12 <= Q) and np.all(lim.upper + 1e-12 >= Q)
    # the positions integrate the velocities
    np.testing.assert_allclose(np.diff(Q, axis=0) / dt, V[1:], atol=1e-9)


def test_implements_the_arm_protocol(pa10):
    sim = SimulatedArm(pa10, ManualClock())
    assert isinstance(sim, Arm)
    s = sim.state()
    assert isinstance(s, JointState)
    np.testing.assert_array_equal(s.q, pa10.home)
    np.testing.assert_array_equal(s.dq, np.zeros(7))


def test_nothing_happens_until_time_advances(pa10):
    clock = ManualClock(5.0)
    sim = SimulatedArm(pa10, clock)
    sim.command_position(np.zeros(7))
    for _ in range(3):
        s = sim.state()
        assert s.t == 5.0
        np.testing.assert_array_equal(s.q, pa10.home)
    assert sim.is_moving()


def test_move_reaches_goal_within_limits_in_the_planned_time(pa10):
    clock = ManualClock()
    sim = SimulatedArm(pa10, clock)
    goal = np.array([0.5, -0.2, 0.3, 1.0, -0.5, 1.2, 0.8])
    expected = plan_move(pa10.home, goal, pa10).duration
    sim.command_position(goal)
    states = run(sim, clock, expected + 0.05)
    assert_states_within_limits(states, pa10.limits)
    np.testing.assert_allclose(states[-1].q, goal, atol=1e-6)
    assert not sim.is_moving()
    assert sim.saturated_steps == 0  # a feasible plan is followed exactly
    moving = [s.t for s in states if np.any(np.abs(s.dq) > 0)]
    assert moving[-1] == pytest.approx(expected, abs=0.0015)


def test_wait_until_idle_sleeps_on_the_clock(pa10):
    clock = ManualClock()
    sim = SimulatedArm(pa10, clock)
    sim.command_position(np.zeros(7))
    assert not sim.wait_until_idle(timeout=0.2)
    assert clock.now() == pytest.approx(0.2)
    assert sim.wait_until_idle(timeout=10.0)
    assert clock.now() < 5.0
    np.testing.assert_allclose(sim.state().q, np.zeros(7), atol=1e-6)


@pytest.mark.parametrize("t_stop", [0.05, 0.15, 0.6])
def test_stop_mid_move_comes_to_rest_in_time_within_limits(pa10, t_stop):
    lim = pa10.limits
    clock = ManualClock()
    sim = SimulatedArm(pa10, clock)
    goal = pa10.home + np.array([1.5, -1.0, 1.5, 0.5, -3.0, 1.5, 2.5])
    sim.command_position(goal)
    before = run(sim, clock, t_stop)
    v0 = before[-1].dq
    sim.stop()
    after = run(sim, clock, 1.0)
    states = before + after
    assert_states_within_limits(states, lim)
    at_rest = next(s.t for s in after if np.all(s.dq == 0))
    t_brake = at_rest - t_stop
    # no faster than the acceleration limit allows; no slower than a jerk-limited brake needs
    lower = np.max(np.abs(v0) / lim.acceleration)
    upper = np.max(np.abs(v0) / lim.acceleration + 3.5 * lim.acceleration / lim.jerk) + 0.002
    assert lower - 0.001 <= t_brake <= upper, (lower, t_brake, upper)
    assert not sim.is_moving()
    assert sim.saturated_steps == 0
    q_rest = after[-1].q
    assert np.all(np.abs(q_rest - goal) > 0.01)  # it did not go on to the goal


def test_stop_when_idle_does_nothing(pa10):
    clock = ManualClock()
    sim = SimulatedArm(pa10, clock)
    sim.stop()
    clock.advance(1.0)
    np.testing.assert_array_equal(sim.state().q, pa10.home)
    assert not sim.is_moving()


def test_new_command_while_moving_is_smooth(pa10):
    clock = ManualClock()
    sim = SimulatedArm(pa10, clock)
    sim.command_position(pa10.home + 0.6)
    states = run(sim, clock, 0.3)
    other = pa10.home - np.array([0.5, 0.3, 0.5, 0.3, 0.5, 0.3, 0.5])
    sim.command_position(other)
    states += run(sim, clock, 4.0)
    assert_states_within_limits(states, pa10.limits)
    np.testing.assert_allclose(states[-1].q, other, atol=1e-6)
    assert sim.saturated_steps == 0


def test_infeasible_command_is_followed_as_closely_as_the_limits_allow(pa10):
    """A trajectory starting at full speed while the arm is at rest: the servo saturates, says so,
    keeps every limit, and catches up with the reference."""
    lim = pa10.limits
    clock = ManualClock()
    sim = SimulatedArm(pa10, clock)
    v = np.zeros(7)
    v[3] = 2.0  # E1 at its velocity limit from the first sample
    traj = plan_move(pa10.home, pa10.home + np.array([0, 0, 0, -1.0, 0, 0, 0]), pa10, v_start=v)
    sim.command_trajectory(traj)
    states = run(sim, clock, traj.duration + 0.5)
    assert_states_within_limits(states, lim)
    assert sim.saturated_steps > 0
    A = np.diff(np.array([s.dq for s in states]), axis=0) / 0.001
    assert np.max(np.abs(A[:, 3])) == pytest.approx(lim.acceleration[3], rel=1e-6)  # it used all it had
    np.testing.assert_allclose(states[-1].q, traj.positions[-1], atol=1e-6)
    assert not sim.is_moving()


def test_trajectory_ending_in_motion_continues_into_a_brake(pa10):
    """A throw ends at the release, at speed: the arm passes it exactly and brakes seamlessly."""
    clock = ManualClock()
    sim = SimulatedArm(pa10, clock)
    v_release = np.array([0, 0.5, 0, 1.5, 0, 5.0, 0])
    traj = plan_move(pa10.home, pa10.home + np.array([0, 0.2, 0, 0.5, 0, 0.8, 0]), pa10, v_goal=v_release)
    sim.command_trajectory(traj)
    n_grid = traj.times.size - 2  # the last sample (the release) is between two servo steps
    states = run(sim, clock, n_grid * 0.001)
    np.testing.assert_allclose(states[-1].q, traj.positions[n_grid], atol=1e-9)
    np.testing.assert_allclose(states[-1].dq, v_release, atol=np.max(pa10.acceleration_limit) * 0.002)
    states += run(sim, clock, 1.0)
    assert_states_within_limits(states, pa10.limits)
    assert sim.saturated_steps == 0
    assert not sim.is_moving()
    # the brake continued from the release state: positions at the release time match it
    t = np.array([s.t for s in states])
    Q = np.array([s.q for s in states])
    q_at_release = np.array([np.interp(traj.duration, t, Q[:, j]) for j in range(7)])
    np.testing.assert_allclose(q_at_release, traj.positions[-1], atol=np.max(pa10.acceleration_limit) * 0.001**2)


def test_trajectory_planned_from_the_noisy_state_is_followed_without_saturation(pa10):
    clock = ManualClock()
    sim = SimulatedArm(pa10, clock, rng=np.random.default_rng(32), tracking_error_rad=1e-3)
    clock.advance(0.1)
    s0 = sim.state()
    assert np.max(np.abs(s0.q - sim.ideal_state().q)) > 1e-4  # the reported state is off the servo's
    traj = plan_move(s0.q, s0.q + 0.3, pa10)
    sim.command_trajectory(traj)
    states = [s0] + run(sim, clock, traj.duration + 0.2)
    assert sim.saturated_steps == 0
    Q = np.array([s.q for s in states])
    jumps = np.abs(np.diff(Q, axis=0)) - pa10.velocity_limit * 0.001
    innovation = 1e-3 * np.sqrt(1 - np.exp(-2 * 0.001 / 0.02))  # std of the AR(1) noise's step
    assert np.max(jumps) < 5.5 * innovation  # no step beyond what the noise itself does
    np.testing.assert_allclose(sim.ideal_state().q, s0.q + 0.3, atol=1e-6)


def test_start_gap_decays_with_the_tracking_time_constant(pa10):
    clock = ManualClock()
    sim = SimulatedArm(pa10, clock)  # no tracking noise
    start = pa10.home + 0.005
    traj = plan_move(start, start + 0.2, pa10)
    sim.command_trajectory(traj)
    np.testing.assert_array_equal(sim.state().q, pa10.home)  # reported position does not jump
    clock.advance(0.02)  # one time constant
    gap = sim.state().q - sim.ideal_state().q
    np.testing.assert_allclose(gap, -0.005 * np.exp(-1.0), rtol=1e-6)
    clock.advance(traj.duration)
    np.testing.assert_allclose(sim.state().q, start + 0.2, atol=1e-9)
    assert sim.saturated_steps == 0


def test_commands_are_validated(pa10):
    clock = ManualClock()
    sim = SimulatedArm(pa10, clock)
    goal = pa10.home.copy()
    goal[1] = np.radians(95)  # S2 limit is 91 deg
    with pytest.raises(LimitError, match="joint S2") as e:
        sim.command_position(goal)
    assert e.value.joint == "S2"
    far = plan_move(np.zeros(7), np.zeros(7) + 0.1, pa10)
    with pytest.raises(RobotError, match="starts .* rad away from the arm"):
        sim.command_trajectory(far)
    bad = JointTrajectory([0.0, 0.001], np.array([pa10.home, pa10.home + 0.01]), np.zeros((2, 7)), np.zeros((2, 7)))
    with pytest.raises(LimitError, match="finite-difference velocity"):
        sim.command_trajectory(bad)
    clock.advance(1.0)
    assert not sim.is_moving()
    np.testing.assert_array_equal(sim.state().q, pa10.home)


def test_irregular_clock_steps_give_the_same_motion(pa10):
    goal = pa10.home + 0.4
    c1, c2 = ManualClock(), ManualClock()
    a, b = SimulatedArm(pa10, c1), SimulatedArm(pa10, c2)
    a.command_position(goal)
    b.command_position(goal)
    rng = np.random.default_rng(30)
    while c2.now() < 1.0:
        c2.advance(rng.uniform(0.0, 0.02))
        s = b.state()
        assert s.t <= c2.now() < s.t + 0.001 + 1e-12
    c1.advance(c2.now())
    sa, sb = a.state(), b.state()
    assert sa.t == sb.t
    np.testing.assert_allclose(sa.q, sb.q, atol=1e-12)


@pytest.mark.parametrize("tracking_error_rad", [0.0, 1e-3])
def test_reads_every_10_ms_equal_the_servo_stepped_one_step_at_a_time(pa10, tracking_error_rad):
    """A reader at 100 Hz (the simulated remotes') of the 1 kHz servo takes ten steps per read,
    the exact-following ones at once: the same reported and ideal states, to the bit, as one step
    at a time, over a move, a new command mid-move, a stop and the rest after it, with and
    without tracking error (its draws one per step either way)."""
    arms, clocks = [], []
    for cls in (PerStepArm, SimulatedArm):
        clock = ManualClock()
        arms.append(cls(pa10, clock, rng=np.random.default_rng(7), tracking_error_rad=tracking_error_rad))
        clocks.append(clock)
    reads = {0: [], 1: []}
    for i in range(300):
        for k, (arm, clock) in enumerate(zip(arms, clocks, strict=True)):
            clock.advance(0.01 if i % 7 else 0.0013)  # and an off-grid read now and then
            if i == 0:
                arm.command_position(pa10.home + 0.4)
            elif i == 60:
                arm.command_position(pa10.home - 0.2)
            elif i == 120:
                arm.stop()
            state, ideal = arm.state(), arm.ideal_state()
            reads[k].append(np.concatenate([[state.t], state.q, state.dq, ideal.q, arm.acceleration]))
    np.testing.assert_array_equal(np.array(reads[1]), np.array(reads[0]))
    assert arms[0].saturated_steps == arms[1].saturated_steps
    assert arms[1].command_kind == "" and np.ptp(np.array(reads[1])[:, 1:8], axis=0).max() > 0.3  # moved, rests


def test_tracking_error_statistics_match_the_setting(pa10):
    sigma = 1e-3
    clock = ManualClock()
    sim = SimulatedArm(pa10, clock, rng=np.random.default_rng(31), tracking_error_rad=sigma)
    sim.command_position(pa10.home + 0.3)
    errors = []
    for _ in range(2000):  # 20 s, sampled every 10 ms (while moving, then at rest)
        clock.advance(0.01)
        errors.append(sim.state().q - sim.ideal_state().q)
    E = np.array(errors)
    assert np.std(E) == pytest.approx(sigma, rel=0.08)
    assert np.all(np.std(E, axis=0) > 0.8 * sigma) and np.all(np.std(E, axis=0) < 1.2 * sigma)
    assert abs(np.mean(E)) < 0.15 * sigma
    # correlated over the 20 ms correlation time: lag-1 (10 ms) autocorrelation ~ exp(-0.5) = 0.61
    r1 = np.mean([np.corrcoef(E[:-1, j], E[1:, j])[0, 1] for j in range(7)])
    assert r1 == pytest.approx(np.exp(-0.5), abs=0.08)
    # the servo itself still reached the goal
    np.testing.assert_allclose(sim.ideal_state().q, pa10.home + 0.3, atol=1e-6)


def test_tracking_error_is_seeded(pa10):
    def trace(seed):
        clock = ManualClock()
        sim = SimulatedArm(pa10, clock, rng=np.random.default_rng(seed), tracking_error_rad=1e-3)
        out = []
        for _ in range(50):
            clock.advance(0.01)
            out.append(sim.state().q)
        return np.array(out)

    np.testing.assert_array_equal(trace(1), trace(1))
    assert np.max(np.abs(trace(1) - trace(2))) > 1e-4


def test_no_tracking_error_by_default(pa10):
    clock = ManualClock()
    sim = SimulatedArm(pa10, clock)
    sim.command_position(pa10.home + 0.2)
    for _ in range(100):
        clock.advance(0.007)
        np.testing.assert_array_equal(sim.state().q, sim.ideal_state().q)


def test_stop_from_another_thread_while_a_loop_reads_the_state(pa10):
    lim = pa10.limits
    clock = ManualClock()
    sim = SimulatedArm(pa10, clock)
    sim.command_position(pa10.home + np.array([1.5, -1.0, 1.5, 0.5, -3.0, 1.5, 2.5]))
    states, failures = [], []
    stop_now, stopped = threading.Event(), threading.Event()

    def step():
        clock.advance(0.001)
        states.append(sim.state())

    def loop():
        try:
            for _ in range(300):
                step()
            stop_now.set()
            # the UI's stop lands whenever its thread runs (late on a loaded machine): the loop goes
            # on reading meanwhile, then 1.2 s more, the time the arm needs to brake to rest
            while not stopped.is_set() and len(states) < 100_000:
                step()
            for _ in range(1200):
                step()
        except Exception as exc:
            failures.append(exc)

    def ui():
        stop_now.wait(5.0)
        sim.stop()
        stopped.set()

    threads = [threading.Thread(target=loop), threading.Thread(target=ui)]
    for t in threads:
        t.start()
    for t in threads:
        t.join(10.0)
    assert failures == []
    assert sim.command_kind == ""
    assert not sim.is_moving()
    V = np.array([s.dq for s in states])
    assert np.all(np.abs(V) <= lim.velocity * (1 + 1e-9))
    # states read by the loop are in time order; acceleration between consecutive distinct steps is limited
    t = np.array([s.t for s in states])
    assert np.all(np.diff(t) >= 0)
    keep = np.concatenate([[True], np.diff(t) > 0])
    tt, VV = t[keep], V[keep]
    A = np.diff(VV, axis=0) / np.diff(tt)[:, None]
    assert np.all(np.abs(A) <= lim.acceleration * (1 + 1e-6))


class RealClock:
    def now(self) -> float:
        return time.monotonic()

    def sleep(self, seconds: float) -> None:
        time.sleep(max(0.0, seconds))


def test_keeps_up_with_a_real_clock(pa10):
    clock = RealClock()
    sim = SimulatedArm(pa10, clock)
    goal = pa10.home + 0.05
    duration = plan_move(pa10.home, goal, pa10).duration
    t0 = clock.now()
    sim.command_position(goal)
    assert sim.wait_until_idle(timeout=5.0)
    elapsed = clock.now() - t0
    assert (
        duration - 0.002 <= elapsed < duration + 3.0
    )  # never ahead of the clock; late only by what a loaded machine adds
    np.testing.assert_allclose(sim.state().q, goal, atol=1e-6)
    assert sim.state().t <= clock.now()


def test_bad_settings(pa10):
    with pytest.raises(RobotError, match="rate_hz"):
        SimulatedArm(pa10, ManualClock(), rate_hz=0)
    with pytest.raises(RobotError, match="tracking_error_rad"):
        SimulatedArm(pa10, ManualClock(), tracking_error_rad=-1e-3)
    with pytest.raises(LimitError, match="q0"):
        SimulatedArm(pa10, ManualClock(), q0=np.full(7, 3.0))
