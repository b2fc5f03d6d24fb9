"""The positions a simulated arm reported over its last steps (`robot/position_history.py`,
`SimulatedArm.position_at`): what a real-time world's remote, making a report late, sees."""

from __future__ import annotations

import numpy as np
import pytest

from wiithrow.clock import SimClock
from wiithrow.robot import SimulatedArm, load_arm
from wiithrow.robot.position_history import PositionHistory


def test_the_ring_keeps_the_newest_steps_and_forgets_the_older():
    history = PositionHistory(4, 2)
    history.keep_steps(0, np.arange(12.0).reshape(6, 2))  # steps 0-5: only 2-5 fit
    assert history.at(1) is None and history.at(6) is None
    np.testing.assert_array_equal(history.at(2), [4.0, 5.0])
    np.testing.assert_array_equal(history.at(5), [10.0, 11.0])
    history.keep_same(6, 3, np.array([-1.0, -2.0]))  # steps 6-8 at rest
    assert history.at(4) is None
    np.testing.assert_array_equal(history.at(8), [-1.0, -2.0])
    np.testing.assert_array_equal(history.at(5), [10.0, 11.0])
    history.keep(9, np.array([7.0, 7.0]))
    np.testing.assert_array_equal(history.at(9), [7.0, 7.0])
    with pytest.raises(ValueError, match="at least one step"):
        PositionHistory(0, 2)


@pytest.mark.parametrize("noise", [0.0, 2e-4])
def test_an_arm_read_late_says_where_it_was_at_each_earlier_step(noise):
    """A move read every millisecond against the same move read once at its end and asked for each
    millisecond's position: the same positions (the tracking error aside, which the late reader takes
    at the stretch's end), while the arm went 0.3 rad."""
    model = load_arm("pa10")
    goal = model.home.copy()
    goal[0] += 0.3
    times = np.arange(1, 400) * 1e-3
    seen = []
    for late in (False, True):
        clock = SimClock()
        arm = SimulatedArm(model, clock, tracking_error_rad=noise, rng=np.random.default_rng(1), history_steps=512)
        arm.command_position(goal)
        if late:
            clock.advance(0.5)
            seen.append([arm.position_at(t) for t in times])
        else:
            got = []
            for t in times:
                clock.advance(t - clock.now())
                got.append(arm.state().q)
            seen.append(got)
    on_time, read_late = np.array(seen[0]), np.array(seen[1])
    assert np.ptp(on_time[:, 0]) > 0.2  # it moved
    np.testing.assert_allclose(read_late, on_time, rtol=0, atol=8 * noise + 1e-12)
    assert read_late[-1, 0] < goal[0] - 1e-3  # (at 0.4 s, not yet where it is at 0.5 s)


def test_without_a_history_or_beyond_it_the_arm_says_where_it_is_now():
    model = load_arm("pa10")
    clock = SimClock()
    goal = model.home.copy()
    goal[0] += 0.3
    for steps in (0, 50):
        arm = SimulatedArm(model, clock, history_steps=steps)
        arm.command_position(goal)
        clock.advance(0.3)
        now = arm.state().q
        np.testing.assert_array_equal(arm.position_at(clock.now() - 0.2), now)  # 200 steps back


def test_an_arm_read_late_says_how_fast_it_moved_at_each_earlier_step():
    """`state_at`: the velocity of each past step, as a reader at that step saw it (velocities carry
    no tracking error), and its time on the step grid; None beyond the history or without one."""
    model = load_arm("pa10")
    goal = model.home.copy()
    goal[0] += 0.3
    times = np.arange(1, 400) * 1e-3 + 0.0004  # between steps: the step at or before each
    seen = []
    for late in (False, True):
        clock = SimClock()
        arm = SimulatedArm(model, clock, tracking_error_rad=2e-4, rng=np.random.default_rng(1), history_steps=512)
        arm.command_position(goal)
        if late:
            clock.advance(0.5)
            states = [arm.state_at(t) for t in times]
            assert all(s is not None for s in states)
            seen.append([(s.t, *s.dq) for s in states if s is not None])
        else:
            got = []
            for t in times:
                clock.advance(t - clock.now())
                state = arm.state()
                got.append((state.t, *state.dq))
            seen.append(got)
    on_time, read_late = np.array(seen[0]), np.array(seen[1])
    assert np.ptp(on_time[:, 1]) > 0.2  # joint 1 sped up and slowed down
    np.testing.assert_allclose(read_late, on_time, rtol=0, atol=1e-9)
    bare = SimulatedArm(model, SimClock())
    assert bare.state_at(-1.0) is None and arm.state_at(clock.now() - 1.0) is None  # none kept, or too old
