"""Faults injected into a running throw, at every phase: whatever raises (the rig's poll, the world,
a driver, a Stop, Ctrl-C), the throw ends safely (`wiithrow.app.throws.safe_stop`): the hand opened
at the release or kept the ball as the phase demands, the arm at rest within 1 s of world time, the
session idle with the reason shown, the throw in the history as failed, no traceback."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pytest

from tests.helpers.host_timed_hand import HostTimedHand
from tests.helpers.sim_fixtures import target_at
from wiithrow.app.errors import expected_errors
from wiithrow.app.session import Operation, Session, simulated_session
from wiithrow.app.settings import Settings
from wiithrow.app.throws.execution import execute_throw, planning_start, return_home
from wiithrow.app.throws.safe_stop import Phase, ThrowFailed, ThrowInterrupted
from wiithrow.app.worlds.hardware import HardwareWorld
from wiithrow.robot.errors import RobotError
from wiithrow.web.operations import OperationRunner
from wiithrow.web.panels import preview_text, throws_table

#: What the garbage sample of issue 20 raised inside the rig's poll.
GARBAGE = AttributeError("'str' object has no attribute 'position'")
#: The arm is at rest (rad/s): the kinematic arm stops exactly; the MuJoCo arm's driver calls a
#: joint at rest below its moving threshold.
REST_RAD_S = {"kinematic": 1e-9, "mujoco": 0.005}
#: The MuJoCo devices as `wiithrow serve --settings` loads them.
MUJOCO_SETTINGS = Path(__file__).resolve().parents[2] / "examples" / "mujoco_settings.json"


@dataclass
class Injected:
    """When an injected fault fired (world clock, s), and how fast the arm moved then (rad/s)."""

    t: float = float("nan")
    speed: float = float("nan")

    @property
    def fired(self) -> bool:
        return bool(np.isfinite(self.t))


def inject(monkeypatch, world, owner, name: str, when: Callable[[], bool], exc: BaseException) -> Injected:
    """Make `owner.name` raise `exc` once, at its first call for which `when()` holds."""
    original = getattr(owner, name)
    fired = Injected()

    def faulty(*args, **kwargs):
        if not fired.fired and when():
            fired.t = world.clock.now()
            fired.speed = float(np.abs(world.arm.state().dq).max())
            raise exc
        return original(*args, **kwargs)

    monkeypatch.setattr(owner, name, faulty)
    return fired


class Release:
    """When the throw's trajectory was commanded, hence its planned release (world clock, s)."""

    def __init__(self, monkeypatch, world, release_time: float) -> None:
        self.world, self.release_time = world, float(release_time)
        self.t_command = float("nan")
        command = world.arm.command_trajectory

        def spied(traj):
            self.t_command = world.clock.now()
            return command(traj)

        monkeypatch.setattr(world.arm, "command_trajectory", spied)

    @property
    def t(self) -> float:
        return self.t_command + self.release_time

    def at(self, dt: float) -> Callable[[], bool]:
        """From `dt` s after the planned release on (before it: dt < 0)."""
        return lambda: bool(np.isfinite(self.t_command)) and self.world.clock.now() >= self.t + dt - 1e-9


def plan(session, monkeypatch, target_xz=(1.3, 0.1)):
    """A validated throw from the arm's pose, and its release time once it is commanded."""
    world = session.world
    q = planning_start(world)
    throw = session.planner.plan(np.array(target_xz), q1=q[0], q_start=q)
    return throw, Release(monkeypatch, world, throw.release_time)


def assert_ended_safely(world, failed: ThrowFailed | ThrowInterrupted, fired: Injected, phase: Phase, kind: str):
    """The fault fired while the arm moved, the throw ended in `phase`, the arm rests within 1 s of
    the fault (and stays at rest), the reason is one line naming the cause."""
    assert fired.fired, "the fault was never injected"
    fault = failed.fault
    assert fault.phase is phase, fault
    assert "\n" not in str(failed) and fault.reason == str(failed)
    rested = world.clock.now()
    assert rested - fired.t <= 1.0, f"the arm came to rest {rested - fired.t:.2f} s after the fault"
    assert fault.t_rest is not None and fault.t_rest <= rested
    world.clock.sleep(0.2)  # and it stays there
    assert np.abs(world.arm.state().dq).max() <= REST_RAD_S[kind]
    assert not world.arm.is_moving()


@pytest.fixture(scope="module")
def session():
    return simulated_session(seed=3, calibration="true")


@pytest.fixture
def world(session):
    """The kinematic world, the arm brought home after each test."""
    world = session.world
    arm = world.arm
    clamped, saturated = arm.position_clamped_steps, arm.saturated_steps
    yield world
    # the brakes were Ruckig's within the limits: the servo never had to clamp or saturate
    assert arm.position_clamped_steps == clamped and arm.saturated_steps == saturated
    return_home(world)


def test_a_garbage_sample_in_the_wind_up_brakes_the_arm_and_the_hand_keeps_the_ball(world, session, monkeypatch):
    throw, release = plan(session, monkeypatch)
    fired = inject(monkeypatch, world, world.rig, "poll", release.at(-0.1), GARBAGE)
    opened_before = world.gripper.opened_at
    with pytest.raises(ThrowFailed) as info:
        execute_throw(world, throw)
    assert fired.speed > 0.5, "the arm was winding up"
    assert_ended_safely(world, info.value, fired, Phase.WIND_UP, "kinematic")
    assert "'str' object has no attribute 'position'" in str(info.value) and "kept the ball" in str(info.value)
    hand = world.gripper.state()
    assert hand.command == "closed" and hand.holding and world.gripper.opened_at == opened_before
    assert isinstance(info.value, expected_errors()), "shown as one line, never a traceback"


@pytest.mark.parametrize(
    "hand, where",
    [
        ("host-timed", "the hand's open command"),
        ("host-timed", "the rig's first read at or after it"),
        ("scheduled", "the rig's first read at or after it"),
    ],
)
def test_a_fault_at_the_release_still_releases_at_the_planned_time(world, session, monkeypatch, hand, where):
    """A hand the host opens is opened by the boundary at the release when its open command
    raised; a read of the rig never times a host-timed release (`release_timing`), so one that
    raises at the release time finds the hand told already, the throw in flight; a hand that opened
    on its own clock at the release time let go then, and the boundary leaves it (in flight)."""
    if hand == "host-timed":
        monkeypatch.setattr(world, "gripper", HostTimedHand(world.gripper))
    throw, release = plan(session, monkeypatch)
    if where == "the hand's open command":
        fired = inject(
            monkeypatch, world, world.gripper, "open", lambda: True, RobotError("the hand did not acknowledge")
        )
    else:  # the first read at or after the release time raises (the wind-up's last, for a scheduled hand)
        fired = inject(monkeypatch, world, world.rig, "poll", release.at(0.0), GARBAGE)
    with pytest.raises(ThrowFailed) as info:
        execute_throw(world, throw)
    assert fired.speed > 1.0, "the arm was at its release speed"
    phase = Phase.RELEASE if where == "the hand's open command" else Phase.FLIGHT
    assert_ended_safely(world, info.value, fired, phase, "kinematic")
    fault = info.value.fault
    assert fault.released_at is not None and abs(fault.released_at - release.t) < 1e-6
    # the jaws open after the release jitter (2 ms sigma in the settings): on time
    assert world.gripper.state().command == "open"
    assert world.gripper.opened_at is not None and abs(world.gripper.opened_at - release.t) < 0.01


def test_a_driver_fault_in_flight_brakes_the_follow_through(world, session, monkeypatch):
    throw, release = plan(session, monkeypatch)
    encoder = RobotError("joint 3 encoder read timed out")
    # the read the follow-through's wait makes (`wait_while_moving`); the simulated remotes no longer
    # read the arm's driver (they take its positions at their reports' times: `SimWorld.sources_at`)
    fired = inject(monkeypatch, world, world.arm, "is_moving", release.at(0.05), encoder)
    with pytest.raises(ThrowFailed) as info:
        execute_throw(world, throw)
    assert fired.speed > 0.5, "the arm was following through"
    assert_ended_safely(world, info.value, fired, Phase.FLIGHT, "kinematic")
    assert "encoder read timed out" in str(info.value)
    assert world.gripper.state().command == "open" and abs(world.gripper.opened_at - release.t) < 0.01


def test_a_fault_while_measuring_the_landing_uncovers_the_target(world, session, monkeypatch):
    session.set_target(target_at(1.3, 0.0, 0.1))
    throw, release = plan(session, monkeypatch)
    fired = inject(monkeypatch, world, world.rig, "poll", lambda: world.lit()["landing"], GARBAGE)
    with pytest.raises(ThrowFailed) as info:
        execute_throw(world, throw)
    assert_ended_safely(world, info.value, fired, Phase.MEASURING, "kinematic")
    assert world.gripper.state().command == "open" and abs(world.gripper.opened_at - release.t) < 0.01
    lit = world.lit()
    assert not lit["landing"] and lit["target"], "the marker taken away, the target uncovered"


def test_ctrl_c_in_the_wind_up_stays_a_keyboard_interrupt_and_ends_safely(world, session, monkeypatch):
    throw, release = plan(session, monkeypatch)
    fired = inject(monkeypatch, world, world.rig, "poll", release.at(-0.6), KeyboardInterrupt())
    with pytest.raises(KeyboardInterrupt) as info:
        execute_throw(world, throw)
    assert isinstance(info.value, ThrowInterrupted) and "interrupted" in str(info.value)
    assert_ended_safely(world, info.value, fired, Phase.WIND_UP, "kinematic")
    assert world.gripper.state().holding


def test_the_session_records_the_failed_throw_and_says_why(world, session, monkeypatch, capsys):
    """The throw operation as the dashboard runs it (a worker, notifications): idle afterwards, the
    reason shown, the throw failed in the history and in *Last throws*, no traceback printed."""
    session.set_target(target_at(1.3, 0.15, 0.1))
    assert session.align().converged
    preview = session.plan_preview()
    release = Release(monkeypatch, world, preview.throw.release_time)
    fired = inject(monkeypatch, world, world.rig, "poll", release.at(0.25 - release.release_time), GARBAGE)
    before = len(session.history)
    told = []
    runner = OperationRunner(session, lambda client, title, body, color: told.append((title, body, color)))
    assert runner.start(Operation.THROW, lambda: session.throw(preview.id))
    runner.join(60.0)
    assert not runner.running
    assert told and told[-1][0] == "Throw did not complete" and told[-1][2] == "red", told
    assert "Traceback" not in capsys.readouterr().err
    s = session.snapshot()
    assert not s.busy and s.operation is None
    record = s.history[-1]
    assert len(s.history) == before + 1 and record.failure is not None
    assert "in the wind-up" in record.failure and "'str' object" in record.failure
    assert s.message == record.failure == told[-1][1]
    assert np.isnan(record.landing_xz).all() and np.isnan(record.error_m)
    assert record.to_dict()["failure"] == record.failure
    table = throws_table(s).splitlines()[2]
    assert table.startswith(f"| {record.index} |") and "**failed**" in table and "nan" not in table
    assert "failed" in preview_text(s) and "nan" not in preview_text(s)
    assert np.abs(world.arm.state().dq).max() == 0.0 and world.clock.now() - fired.t <= 1.2
    assert world.gripper.state().holding, "the hand kept the ball"


def test_stop_in_the_wind_up_brakes_keeps_the_ball_and_is_recorded(world, session, monkeypatch):
    session.set_target(target_at(1.3, -0.1, 0.1))
    assert session.align().converged
    preview = session.plan_preview()
    stop_now = Release(monkeypatch, world, preview.throw.release_time).at(-0.15)
    pressed = []
    poll = world.rig.poll

    def press_stop_then_read():  # the operator presses Stop while the arm winds up
        if not pressed and stop_now():
            pressed.append(world.clock.now())
            session.stop()
        return poll()

    monkeypatch.setattr(world.rig, "poll", press_stop_then_read)
    with pytest.raises(ThrowFailed, match="stopped by the operator") as info:
        session.throw(preview.id)
    assert info.value.fault.phase is Phase.WIND_UP and "scheduled open was cancelled" in str(info.value)
    assert world.clock.now() - pressed[0] <= 1.0 and np.abs(world.arm.state().dq).max() == 0.0
    assert world.gripper.state().holding
    s = session.snapshot()
    assert not s.busy and s.message == s.history[-1].failure and "stopped by the operator" in s.message


def test_mujoco_a_garbage_sample_in_the_wind_up_and_a_hand_fault_at_the_release(monkeypatch):
    """The MuJoCo world, through the drivers a real arm and hand have: the ball stays between the
    pads of the braked arm (its scheduled open cancelled); a host-timed hand's failed open command
    is retried at the planned release time."""
    mujoco = simulated_session(seed=4, world="mujoco", calibration="true")
    world = mujoco.world
    throw, release = plan(mujoco, monkeypatch)
    fired = inject(monkeypatch, world, world.rig, "poll", release.at(0.25 - release.release_time), GARBAGE)
    with pytest.raises(ThrowFailed) as info:
        execute_throw(world, throw)
    assert fired.speed > 0.5
    assert_ended_safely(world, info.value, fired, Phase.WIND_UP, "mujoco")
    assert world.gripper.state().command == "closed" and world.lab.holding(), "the ball is still in the hand"
    assert world.lab.events.opened_at is None

    assert "scheduled open was cancelled" in str(info.value)

    monkeypatch.undo()
    return_home(world)
    monkeypatch.setattr(world, "gripper", HostTimedHand(world.gripper))
    throw, release = plan(mujoco, monkeypatch)
    fired = inject(monkeypatch, world, world.gripper, "open", lambda: True, RobotError("the hand did not acknowledge"))
    with pytest.raises(ThrowFailed) as info:
        execute_throw(world, throw)
    assert_ended_safely(world, info.value, fired, Phase.RELEASE, "mujoco")
    # the lab's hand opens after its latency (10 ms +- 3 ms): the ball left on time
    opened = world.lab.events.opened_at
    assert opened is not None and 0.0 <= opened - release.t < 0.025
    assert not world.lab.holding()


@pytest.mark.slow
def test_mujoco_served_as_hardware_in_real_time_brakes_on_a_garbage_sample(monkeypatch):
    """The incident of issue 20 on the system clock, with the MuJoCo drivers `serve --settings`
    loads: the arm keeps moving by itself while the boundary acts, and still rests within 1 s."""
    world = HardwareWorld(Settings.load(MUJOCO_SETTINGS))
    session = Session(world, rng=np.random.default_rng(0))
    try:
        session.use_calibration(world.true_calibration())
        world.connect()
        throw, release = plan(session, monkeypatch)
        fired = inject(monkeypatch, world, world.rig, "poll", release.at(0.25 - release.release_time), GARBAGE)
        with pytest.raises(ThrowFailed) as info:
            execute_throw(world, throw)
        assert fired.speed > 0.5
        assert_ended_safely(world, info.value, fired, Phase.WIND_UP, "mujoco")
        assert world.gripper.state().command == "closed" and world.gripper.state().holding
    finally:
        session.close()
