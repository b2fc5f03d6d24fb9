"""The scheduled release (`robot.gripper.ScheduledOpen`): a hand told `open_at(t_release)` with the
trajectory opens at that time on its own clock, however late the host gets round to the release;
a Stop before it cancels it (the hand keeps the ball); a hand without it is opened by the host,
never later than the release bound: a host later than that keeps the ball
(`wiithrow.app.throws.release_timing`)."""

from __future__ import annotations

import numpy as np
import pytest

from tests.helpers.host_timed_hand import HostTimedHand
from wiithrow.app.session import simulated_session
from wiithrow.app.throws.execution import execute_throw, planning_start, return_home
from wiithrow.app.throws.release_timing import RELEASE_LATE_BOUND_S
from wiithrow.app.throws.safe_stop import Phase, ThrowFailed
from wiithrow.clock import SimClock
from wiithrow.robot.gripper import SimulatedGripper, schedules_open

#: How late the host gets round to the release in these tests (s): a loaded host's oversleep.
HOST_LATE_S = 0.05


def test_the_simulated_hand_opens_at_its_scheduled_time_when_nobody_reads_it_then():
    clock = SimClock()
    hand = SimulatedGripper(clock, latency_s=0.01)
    assert schedules_open(hand) and not schedules_open(HostTimedHand(hand))
    hand.load_ball()
    hand.close()
    clock.advance(0.1)
    t_release = clock.now() + 0.2
    hand.open_at(t_release)
    assert hand.state().command == "closed" and hand.state().holding
    clock.advance(0.2 + HOST_LATE_S)  # the host sleeps past the release
    assert hand.opened_at == pytest.approx(t_release + 0.01, abs=1e-12)
    assert hand.state().command == "open" and not hand.state().holding
    assert not hand.cancel_open(), "its time came: nothing left to cancel"


def test_a_cancelled_scheduled_open_never_happens():
    clock = SimClock()
    hand = SimulatedGripper(clock)
    hand.load_ball()
    hand.close()
    clock.advance(0.1)
    hand.open_at(clock.now() + 0.2)
    clock.advance(0.1)
    assert hand.cancel_open()
    clock.advance(1.0)
    assert hand.opened_at is None and hand.state().command == "closed" and hand.state().holding


@pytest.fixture(scope="module")
def mujoco():
    return simulated_session(seed=5, world="mujoco", calibration="true")


def late_host(monkeypatch, world, throw) -> list[float]:
    """Make the host oversleep the release by HOST_LATE_S: the wind-up's first sleep on the world's
    clock sleeps through it. Returns the planned release time once the trajectory is commanded."""
    t_release: list[float] = []
    command, sleep = world.arm.command_trajectory, world.clock.sleep

    def commanded(traj):
        t_release.append(world.clock.now() + throw.release_time)
        return command(traj)

    def oversleeping(seconds):
        if len(t_release) == 1 and world.clock.now() < t_release[0]:
            t_release.append(world.clock.now())  # (once)
            seconds = t_release[0] + HOST_LATE_S - world.clock.now()
        return sleep(seconds)

    monkeypatch.setattr(world.arm, "command_trajectory", commanded)
    monkeypatch.setattr(world.clock, "sleep", oversleeping)
    return t_release


@pytest.mark.parametrize("hand", ["scheduled", "host-timed"])
def test_mujoco_the_ball_leaves_at_the_release_time_on_the_drivers_clock_when_the_host_is_late(
    mujoco, monkeypatch, hand
):
    world = mujoco.world
    if hand == "host-timed":
        monkeypatch.setattr(world, "gripper", HostTimedHand(world.gripper))
    q = planning_start(world)
    throw = mujoco.planner.plan(np.array([1.3, 0.1]), q1=q[0], q_start=q)
    t_release = late_host(monkeypatch, world, throw)
    try:
        if hand == "scheduled":
            execute_throw(world, throw, measure=False)
        else:  # the host woke beyond the release bound: it does not open the hand late
            with pytest.raises(ThrowFailed, match=f"{1e3 * HOST_LATE_S:.0f} ms after its time") as info:
                execute_throw(world, throw, measure=False)
    finally:
        monkeypatch.undo()
        return_home(world)
    assert len(t_release) == 2, "the host never overslept"
    opened = world.lab.events.opened_at
    if hand == "host-timed":
        assert HOST_LATE_S > RELEASE_LATE_BOUND_S
        assert info.value.fault.phase is Phase.WIND_UP and "kept the ball" in str(info.value)
        assert opened is None and world.lab.holding(), "the hand kept the ball"
        return
    h = world.lab.h
    delay = world.lab.gripper_delays[-1]  # the open's latency + jitter, as drawn
    assert opened is not None
    late = opened - (t_release[0] + delay)
    # the fingers start to open at the step the latency ends after t_release
    assert -1e-9 <= late <= h + 1e-9, f"the hand opened {1e3 * late:.2f} ms after its scheduled time"
    reported = world.gripper.last_open_time()  # what the throw checks against the release bound
    assert reported is not None and abs(reported - t_release[0]) < 1e-9, reported


def test_mujoco_stop_before_the_release_cancels_the_scheduled_open(mujoco, monkeypatch):
    world = mujoco.world
    q = planning_start(world)
    throw = mujoco.planner.plan(np.array([1.4, 0.2]), q1=q[0], q_start=q)
    t_release: list[float] = []
    command = world.arm.command_trajectory

    def commanded(traj):
        t_release.append(world.clock.now() + throw.release_time)
        return command(traj)

    monkeypatch.setattr(world.arm, "command_trajectory", commanded)
    stopped = []

    def stop_before_release():
        hit = bool(t_release) and world.clock.now() >= t_release[0] - 0.1
        stopped.extend([world.clock.now()] if hit and not stopped else [])
        return bool(stopped)

    try:
        with pytest.raises(ThrowFailed, match="stopped by the operator") as info:
            execute_throw(world, throw, cancel=stop_before_release)
        fault = info.value.fault
        assert fault.phase is Phase.WIND_UP and "scheduled open was cancelled" in fault.reason, fault.reason
        assert stopped[0] < t_release[0]
        world.clock.sleep(max(0.0, t_release[0] + 0.2 - world.clock.now()))  # well past the release time
        assert world.lab.events.opened_at is None and world.lab.holding(), "the hand kept the ball"
        assert world.gripper.state().command == "closed"
    finally:
        monkeypatch.undo()
        return_home(world)  # (the ball stays in the hand, for the next throw)
