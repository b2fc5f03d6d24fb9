"""Joint-1 alignment on the simulated world: converges from several starts, searches for a target
out of view, follows a moving one, stops on a lost one, respects joint 1's limits."""

import math

import numpy as np
import pytest

from wiithrow.app.alignment import AlignmentOptions, Joint1Commander, align_joint1, sweep_waypoints
from wiithrow.app.errors import AppError
from wiithrow.app.rig.waiting import pump
from wiithrow.app.worlds import SimWorld


@pytest.fixture(scope="module")
def world():
    w = SimWorld(seed=11)
    w.connect()
    w.rig.set_calibration(w.true_calibration_Ps())  # the alignment's own accuracy, not the calibration's
    pump(w.clock, w.rig, 0.1, step_s=0.01)
    return w


def _start(world, q1):
    q = world.arm.state().q.copy()
    q[0] = q1
    world.arm.command_position(q)
    pump(world.clock, world.rig, 4.0, step_s=0.01)


def _place_target(world, link1_xyz):
    """Light the target at a position given in the current link1."""
    T = world.arm_model.frame_placement(world.arm.state().q, "link1")
    p = T[:3, :3] @ np.asarray(link1_xyz, dtype=float) + T[:3, 3]
    world.light("target", True, p)
    return p


@pytest.mark.parametrize(
    "q1, target",
    [
        (0.0, (2.0, 0.3, 0.0)),  # floor, 2 m, 8.5 deg to the side
        (0.5, (1.2, -0.18, 0.4)),  # table height, near, at the edge of the view
        (-0.4, (2.5, 0.6, 0.5)),  # far corner of the throwing area
        (1.2, (1.5, 0.0, 0.2)),  # already aligned
        (-1.0, (1.0, 0.15, 0.05)),  # near the floor at 1 m
    ],
)
def test_converges_below_5_mm_within_3_s(world, q1, target):
    _start(world, q1)
    p = _place_target(world, target)
    saturated = world.arm.saturated_steps
    result = align_joint1(world)
    world.light("target", False)
    assert result.status == "converged", result.message
    assert result.duration_s < 3.0
    assert abs(result.y_m) < 0.005
    assert result.q1 == pytest.approx(math.atan2(p[1], p[0]), abs=0.005 / np.hypot(p[0], p[1]) + 0.003)
    assert np.linalg.norm(result.position_base - p) < 0.02
    assert result.throw_xz == pytest.approx([np.hypot(p[0], p[1]), p[2]], abs=0.02)
    assert not world.arm.is_moving()
    assert world.arm.saturated_steps == saturated  # the streamed commands stayed within the limits


def test_finds_a_target_outside_the_field_of_view(world):
    _start(world, 0.0)
    p = np.array([1.8 * math.cos(-1.4), 1.8 * math.sin(-1.4), 0.1])  # 80 deg to the right
    world.light("target", True, p)
    phases = []
    result = align_joint1(world, progress=lambda phase, y: phases.append(phase))
    world.light("target", False)
    assert result.status == "converged" and abs(result.y_m) < 0.005
    assert "search" in phases and phases[-1] == "track"
    assert result.q1 == pytest.approx(-1.4, abs=0.01)


def test_follows_a_moving_target_until_stopped(world):
    _start(world, 0.0)
    _place_target(world, (2.0, 0.0, 0.0))
    t0 = world.clock.now()
    errors = []

    def move(phase, y):  # the target walks around the arm at 0.15 rad/s
        t = world.clock.now() - t0
        world.light("target", True, [2.0 * math.cos(0.15 * t), 2.0 * math.sin(0.15 * t), 0.0])
        if t > 1.0 and np.isfinite(y):
            errors.append(abs(y))

    result = align_joint1(
        world,
        AlignmentOptions(hold_s=None),
        progress=move,
        cancel=lambda: world.clock.now() - t0 > 4.0,
    )
    world.light("target", False)
    assert result.status == "stopped"
    assert np.median(errors) < 0.005 and max(errors) < 0.02
    assert result.q1 == pytest.approx(0.6, abs=0.03)
    assert not world.arm.is_moving()


def test_a_lost_target_stops_the_arm(world):
    _start(world, 0.0)
    _place_target(world, (1.5, 0.2, 0.1))
    t0 = world.clock.now()

    def vanish(phase, y):
        if world.clock.now() - t0 > 0.5:
            world.light("target", False)

    result = align_joint1(world, AlignmentOptions(hold_s=None), progress=vanish)
    assert result.status == "lost" and "lost" in result.message
    assert result.duration_s < 1.5
    assert not world.arm.is_moving()
    assert np.isfinite(result.position_link1).all()  # the last place it was seen


def test_no_target_and_no_search_says_not_found(world):
    result = align_joint1(world, AlignmentOptions(search=False))
    assert result.status == "not_found" and not world.arm.is_moving()


def test_needs_a_calibrated_rig():
    w = SimWorld(seed=1)
    with pytest.raises(AppError, match="calibrated rig"):
        align_joint1(w)


def test_search_sweep_doubles_and_covers_both_limits():
    points = sweep_waypoints(0.5, -3.0, 3.0, 0.6)
    assert points[:3] == pytest.approx([1.1, -0.7, 2.9])
    assert max(points) == 3.0 and min(points) == -3.0 and points.count(3.0) == 1


def test_commander_brakes_before_the_joint_limit(world):
    _start(world, 2.9)  # PA-10 S1 limit: 3.089 rad
    commander = Joint1Commander(world.arm, world.arm_model.limits, world.clock, world.arm.state().q)
    commander.resync()
    for _ in range(300):
        commander.command(1.0)
        pump(world.clock, world.rig, 0.01, step_s=0.01)
    q1 = world.arm.state().q[0]
    assert q1 < world.arm_model.upper[0] and q1 > 3.0
    assert abs(world.arm.state().dq[0]) < 1e-3
    commander.stop()


def test_commander_rebuilds_a_command_the_arm_refuses_after_a_hold_up(world):
    """A loop held up between reading its reference and commanding (a loaded CPU) while joint 1
    moves fast sends a trajectory that starts behind the arm: the arm refuses it without moving
    (StartMismatchError) and the commander rebuilds it from the measured state."""
    _start(world, 0.0)

    class HeldUpArm:
        """The arm, with every other command delayed by 40 ms of the world's time."""

        def __init__(self, arm) -> None:
            self.arm, self.late = arm, True

        def __getattr__(self, name):
            return getattr(self.arm, name)

        def command_trajectory(self, traj) -> None:
            if self.late:
                pump(world.clock, world.rig, 0.04, step_s=0.01)
            self.late = not self.late
            self.arm.command_trajectory(traj)

    commander = Joint1Commander(HeldUpArm(world.arm), world.arm_model.limits, world.clock, world.arm.state().q)
    commander.resync()
    q0 = world.arm.state().q[0]
    for _ in range(100):
        commander.command(0.8)
        pump(world.clock, world.rig, 0.01, step_s=0.01)
    assert commander.resyncs > 0, "the hold-ups never made a command start behind the arm"
    assert world.arm.state().q[0] - q0 > 0.5, "joint 1 kept moving towards the wanted velocity"
    commander.stop()
    pump(world.clock, world.rig, 1.0, step_s=0.01)


def test_commander_starts_where_the_arm_is_when_the_host_is_held_up_after_reading_it(world):
    """The hold-up of a loaded host between reading the arm and commanding (here 40 ms after every
    read, while joint 1 moves at 0.8 rad/s: 32 mrad, beyond the arm's 10 mrad start tolerance):
    the commander drops the samples that passed, so its rebuilds start where the arm is and the
    alignment goes on (before, every rebuild started as far behind and the error stood)."""
    _start(world, 0.0)

    class SlowReadArm:
        """The arm; every command after the first few is delayed by 40 ms, and so is every state
        read afterwards (the host descheduled just after reading)."""

        def __init__(self, arm) -> None:
            self.arm, self.commands = arm, 0

        def __getattr__(self, name):
            return getattr(self.arm, name)

        def state(self):
            s = self.arm.state()
            if self.commands > 20:
                pump(world.clock, world.rig, 0.04, step_s=0.01)
            return s

        def command_trajectory(self, traj) -> None:
            self.commands += 1
            if self.commands > 20 and self.commands % 2:
                pump(world.clock, world.rig, 0.04, step_s=0.01)
            self.arm.command_trajectory(traj)

    arm = SlowReadArm(world.arm)
    commander = Joint1Commander(arm, world.arm_model.limits, world.clock, world.arm.state().q)
    commander.resync()
    q0 = world.arm.state().q[0]
    for _ in range(60):
        commander.command(0.8)
        pump(world.clock, world.rig, 0.01, step_s=0.01)
    assert commander.resyncs > 0, "the hold-ups never made a command start behind the arm"
    assert world.arm.state().q[0] - q0 > 0.5, "joint 1 kept moving towards the wanted velocity"
    commander.stop()
    pump(world.clock, world.rig, 1.0, step_s=0.01)
