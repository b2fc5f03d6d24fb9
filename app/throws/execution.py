"""Playing a validated throw in the world: the arm moves, the hand lets go, the rig measures where
the ball came down. The same steps run on every world, through the interfaces real hardware has.

Only a `throwing.ValidatedThrow` is executed (the validator is the only way to get one). Steps:

1. check that the throw starts where the arm is (plan it with `q_start` = the arm's state, so that
   the move to the wind-up pose is part of the validated trajectory: nothing else moves the arm);
2. close the hand on the ball (`RigWorld.load_ball`: a simulated operator puts it there; on
   hardware the operator has);
3. command the throw's trajectory and the hand's open at the release time on the world's clock: a
   hand that schedules opens (`robot.gripper.ScheduledOpen`: the MuJoCo and kinematic worlds'
   hands, a real hand whose driver synchronises its IO to the trajectory) is told `open_at(t_release)`
   with the trajectory and opens on its own clock, so a host that gets round to the release late
   does not make the ball leave late (meanwhile this thread reads the rig: a late read cannot
   delay that release); any other hand (*host-timed*) is told `open()` by this thread at the
   release time, waiting on the world's clock only, never on the rig or the network
   (`wiithrow.app.throws.release_timing`: a reader thread keeps reading the rig on a system
   clock). A host that gets round to it later than `release_timing.RELEASE_LATE_BOUND_S` does not
   open the hand: the throw ends in the wind-up (the hand keeps the ball, the arm brakes), saying
   how late. An `open()` that returned beyond the bound, or a hand that reports it opened beyond
   it (`robot.gripper.ReportsOpenTime`), makes a late release (`ThrowExecution.release_late_s`):
   the ball flew, but its landing labels no library. Either hand lets go after its own latency
   and jitter (the kinematic world: the release jitter of the settings; the MuJoCo world: 10 ms
   +- 3 ms by default), so the ball leaves from wherever the arm really is by then. The settings'
   `hand_open_lead_s` (0 by default) tells the hand that long before the planned release: a hand
   told at the release lets go in the follow-through, whose brake makes each millisecond of its
   delay cost about ten millimetres of landing; told its latency and twice its jitter early, it
   lets go on the wind-up's smooth end, a fraction of a millimetre a millisecond, and the learning
   absorbs the steady part (the times below, the release bound's included, count from then). A
   Stop before the release cancels a scheduled open (`cancel_open`: the hand keeps the ball). Meanwhile the hand is
   watched (`wiithrow.app.throws.hand_watch`, off the release's timing path): a ball that left it
   before the release stops the throw (`BallLost`: lost in the wind-up, the arm brakes to rest);
4. the follow-through brakes the arm to rest; a simulated world says what the ball did
   (`RigWorld.await_landing`: the kinematic world flies it with the planner's ballistics down to
   the surface, the MuJoCo world runs physics until its first touchdown); real hardware does not
   know;
5. as in the paper, an IR marker is put where the ball came down (the target covered meanwhile)
   and the stereo rig measures it: the mean of the tracked positions over `MEASURE_S`, in link1
   at joint 1's angle then (the mean of the arm's readings meanwhile, `measured_q1`), is the
   measured landing: in the throw's plane (`measured_plane`: x, the across offset y, z) and in
   `base` (`measured_base`, what the throw's error is taken from:
   `wiithrow.throwing.landing_error`). A simulated world puts the marker there
   itself (`RigWorld.place_landing_marker`); on hardware the operator does, and the measurement
   waits for them (`measure_marker`, the dashboard's *Measure landing*).

The result keeps the true landing (simulation only; NaN on hardware) beside the measured one: the
simulation knows both, the operator only the second, and only the second labels and scores throws.

Whatever is raised during these steps (by the rig, the network, a driver, the world, a Stop) ends
the throw at its boundary (`wiithrow.app.throws.safe_stop`: the body marks each phase with
`entering`): the hand opened at the release or kept the ball as the phase demands, the arm braked
to rest, and a `ThrowFailed` saying why in one line.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from wiithrow.app.errors import AppError
from wiithrow.app.rig.source import newest_t
from wiithrow.app.rig.waiting import Cancel, Cancelled, is_cancelled, pump, wait_while_moving
from wiithrow.app.throws.hand_watch import HAND_WATCH_STEP_S, HandWatch, HandWatchSummary
from wiithrow.app.throws.release_timing import (
    RELEASE_LATE_BOUND_S,
    PeriodicReader,
    late_release_line,
    release_host_timed,
    release_late_s,
    reported_open_late_s,
)
from wiithrow.app.throws.safe_stop import Phase, entering, throw_boundary
from wiithrow.app.worlds import RigWorld
from wiithrow.app.worlds.base import NO_GRIPPER
from wiithrow.robot import JointState
from wiithrow.robot.gripper import ScheduledOpen
from wiithrow.throwing import Ball, ReleaseState, ValidatedThrow
from wiithrow.throwing.throw_plane import turned

MEASURE_S = 0.3  # how long the rig looks at the landing marker
START_TOLERANCE_RAD = 0.005  # the throw must start this close to the arm's pose


@dataclass(frozen=True)
class ThrowExecution:
    """What happened in one throw. Positions in `base` unless named otherwise (m); NaN what is
    unknown (the truth on hardware, a landing not yet measured)."""

    release: ReleaseState  # the ball's release (the planned one on hardware)
    landing_base: NDArray[np.float64]  # where the ball came down (the truth; NaN on hardware)
    landing_link1: NDArray[np.float64]
    measured_link1: NDArray[np.float64]  # the rig's measurement of the landing marker (NaN if unseen)
    flight_base: NDArray[np.float64] = field(repr=False)  # (N, 3) the ball's path
    flight_times: NDArray[np.float64] = field(repr=False)
    q1: float = 0.0
    t_release: float = 0.0  # on the world's clock: the planned release (the hand told `hand_open_lead_s` before it)
    spin: NDArray[np.float64] | None = None  # the ball's angular velocity at the release (rad/s), if known
    # how far the `ball` frame (nominal kinematics of the measured joints) was from the plan's release
    # position when the hand was told to open: the arm's tracking error there (m; NaN when the arm
    # was read too late after the release to say)
    release_tracking_m: float = float("nan")
    # how late (s) after it was due (`t_release` less the lead) the hand opened, when that was beyond the bound
    # (`release_timing.RELEASE_LATE_BOUND_S`): a late release, which labels no library; None: on time
    release_late_s: float | None = None
    # what the wind-up's watch of the hand did (`hand_watch`): its reads, failed reads, longest read
    hand_watch: HandWatchSummary | None = None
    # joint 1's angle (rad) while the rig measured the landing marker: the link1 `measured_link1`
    # is in (NaN: not measured; then taken as the throw's `q1`)
    measured_q1: float = float("nan")

    @property
    def late_release(self) -> str | None:
        """The late release in one line (`release_timing.late_release_line`), None when on time."""
        return None if self.release_late_s is None else late_release_line(self.release_late_s)

    @property
    def measured_plane(self) -> NDArray[np.float64]:
        """The measured landing in the throw's plane (link1 at the throw's `q1`, m): (x, y, z),
        y how far beside the plane it came down (+ toward +y)."""
        at = self.measured_q1 if np.isfinite(self.measured_q1) else self.q1
        return turned(self.measured_link1, at - self.q1)

    @property
    def measured_base(self) -> NDArray[np.float64]:
        """The measured landing in `base` (m): what the throw's error is taken from."""
        return turned(self.measured_plane, self.q1)

    @property
    def measured_xz(self) -> NDArray[np.float64]:
        """The measured landing (x, z) in the throw plane (link1 at the throw's `q1`)."""
        return self.measured_plane[[0, 2]]


def ball_of(world: RigWorld) -> Ball:
    return world.ball()


@throw_boundary
def execute_throw(
    world: RigWorld,
    throw: ValidatedThrow,
    *,
    measure: bool = True,
    cancel: Cancel = None,
    surface_height: float | None = None,
) -> ThrowExecution:
    """Play `throw` in `world` (see the module docstring). Anything raised while it runs (a Stop
    before the release included) ends it safely and is raised as `safe_stop.ThrowFailed`: the arm
    braked to rest, the hand opened at the release or kept the ball, as the phase demands.

    The ball comes down on the real surface: `surface_height` (m, base), by default the lit
    target's true height, else the height the throw was planned for. (The plan uses the target's
    *measured* height; a miscalibrated rig measures it wrong, the floor does not move.) Each
    world draws its own noise."""
    if not isinstance(throw, ValidatedThrow):
        raise AppError("only a validated throw is executed: plan it with the throw planner (it validates)")
    arm, model = world.arm, world.arm_model
    if world.gripper is None:
        raise AppError(NO_GRIPPER)

    _wait_idle(world, cancel)
    gap = np.abs(throw.start_pose - arm.state().q)
    if np.any(gap > START_TOLERANCE_RAD):
        j = int(np.argmax(gap))
        raise AppError(
            f"the throw starts {gap[j]:.3f} rad from the arm at joint {model.joint_names[j]}: plan it from "
            "the arm's current pose (q_start), so the whole motion is validated"
        )
    if surface_height is not None:  # a stated surface (a training target): the world puts it under the plan
        point = np.array(throw.predicted.landing.position, dtype=float)
        point[2] = float(surface_height)
        world.set_surface(point)
    _check_cancel(world, cancel)
    entering(Phase.LOADING)
    world.load_ball(cancel)
    _check_cancel(world, cancel)

    hand = world.gripper
    held = hand.state()  # the grip the wind-up's readings are judged against (`hand_watch`)
    t_command = world.clock.now()
    arm.command_trajectory(throw.trajectory)
    t_release = t_command + throw.release_time
    t_open = t_release - open_lead_s(world)  # when the hand is told to open (module docstring, step 3)
    watch = HandWatch(hand, world.clock, held, t_open)
    scheduled = isinstance(hand, ScheduledOpen)
    entering(Phase.WIND_UP, release_at=t_open, scheduled_open=scheduled)
    readers: list[PeriodicReader] = []
    told_at, returned_at = None, t_open
    if isinstance(hand, ScheduledOpen):  # the hand opens on its own clock (module docstring, step 3)
        hand.open_at(t_open)
        while world.clock.now() < t_open - 1e-9:  # a late read here cannot delay the release
            _check_cancel(world, cancel)
            watch.check()
            pump(world.clock, world.rig, min(HAND_WATCH_STEP_S, t_open - world.clock.now()), step_s=0.01)
    else:  # the host opens it: nothing on the way waits on the rig or the hand (`release_timing`)
        told_at, returned_at, readers = release_host_timed(
            world.clock, world.rig, hand, t_open, lambda: _check_cancel(world, cancel), watch
        )
    entering(Phase.FLIGHT, released_at=told_at)
    told = arm.state()
    world.after_open()
    for reader in readers:  # the rig's reads, then the hand's watch: a ball lost before the release is raised here
        reader.finish()
    tracking = _release_tracking(world, throw, told, t_release, t_open)

    if surface_height is None:
        target = world.source_position_base("target")
        surface_height = float(target[2]) if np.isfinite(target).all() else float(throw.landing_height)
    _wait_idle(world, None)  # the follow-through brakes to rest
    reported = reported_open_late_s(hand, t_open)  # a hand that says when it opened is believed
    late = release_late_s(reported if reported is not None else returned_at - t_open)
    flight = world.await_landing(float(surface_height))
    q1 = float(throw.q1)
    if flight is None:  # real hardware: nobody knows yet
        nan = np.full(3, np.nan)
        return ThrowExecution(
            throw.release,
            nan,
            nan,
            nan,
            np.zeros((0, 3)),
            np.zeros(0),
            q1,
            t_release,
            release_tracking_m=tracking,
            release_late_s=late,
            hand_watch=watch.summary(),
        )
    landing_link1 = world.base_to_link1(flight.landing_base, _with_q1(model.home, q1))[0]
    measured, measured_q1 = np.full(3, np.nan), float("nan")
    if measure and world.place_landing_marker(flight):
        entering(Phase.MEASURING)
        measured, measured_q1 = measure_landing_marker(world)
    return ThrowExecution(
        flight.release,
        np.asarray(flight.landing_base, float),
        landing_link1,
        measured,
        flight.path,
        flight.times,
        q1,
        t_release,
        flight.spin,
        tracking,
        late,
        watch.summary(),
        measured_q1,
    )


def planning_start(world: RigWorld, tolerance_rad: float = 0.002) -> NDArray[np.float64]:
    """The arm's pose to plan a throw from: its measured state, clamped into the joint limits when
    it lies beyond them by no more than `tolerance_rad` (the tracking error of an arm resting at a
    limit); further beyond, AppError."""
    model = world.arm_model
    q = world.arm.state().q
    clamped = np.clip(q, model.lower, model.upper)
    beyond = np.abs(q - clamped)
    if np.any(beyond > tolerance_rad):
        j = int(np.argmax(beyond))
        raise AppError(f"joint {model.joint_names[j]} is {beyond[j]:.4f} rad beyond its limit: move the arm back first")
    return clamped


def return_home(world: RigWorld, cancel: Cancel = None) -> None:
    """Move the arm to its home pose (a Ruckig move within its limits) and wait until it rests."""
    world.arm.command_position(world.arm_model.home)
    _wait_idle(world, cancel)


def _release_tracking(
    world: RigWorld, throw: ValidatedThrow, told: JointState, t_release: float, t_open: float
) -> float:
    """How far the `ball` frame of the arm's state `told` (read once the hand was told to open, at
    `t_open`) was from where the plan has it then (m: its release position, or a lead's earlier
    point); NaN when that state was read beyond the release bound after `t_open` (a late read: the
    arm had moved on, the figure would not be the release's)."""
    if told.t - t_open > RELEASE_LATE_BOUND_S:
        return float("nan")
    if t_open < t_release - 1e-9:  # told early: the plan's pose then
        planned, _, _ = throw.trajectory.sample(np.array([throw.release_time - (t_release - t_open)]))
        where = world.arm_model.frame_position(planned[0], "ball")
    else:
        where = throw.release.position
    return float(np.linalg.norm(world.arm_model.frame_position(told.q, "ball") - where))


def open_lead_s(world: RigWorld) -> float:
    """How long before the planned release the hand is told to open (s): the settings'
    `hand_open_lead_s` (0 for a world without settings of its own)."""
    settings = getattr(world, "settings", None)
    return float(getattr(settings, "hand_open_lead_s", 0.0))


def _with_q1(q: NDArray[np.float64], q1: float) -> NDArray[np.float64]:
    q = np.array(q, dtype=float)
    q[0] = q1
    return q


def _check_cancel(world: RigWorld, cancel: Cancel) -> None:
    if is_cancelled(cancel):
        world.arm.stop()
        raise Cancelled("the throw was stopped before the release; the arm brakes to rest")


def _wait_idle(world: RigWorld, cancel: Cancel, timeout_s: float = 20.0) -> None:
    """Read the rig while the arm moves; a Stop before the release stops the arm (AppError)."""
    try:
        idle = wait_while_moving(world.arm, world.clock, world.rig, timeout_s=timeout_s, step_s=0.01, cancel=cancel)
    except Cancelled:
        _check_cancel(world, cancel)
        raise
    if not idle:
        world.arm.stop()
        raise AppError(f"the arm did not come to rest within {timeout_s:.0f} s")


def measure_marker(world: RigWorld, cancel: Cancel = None) -> NDArray[np.float64]:
    """Measure the landing marker with the rig, in link1 (`measure_landing_marker`'s point)."""
    return measure_landing_marker(world, cancel)[0]


def measure_landing_marker(world: RigWorld, cancel: Cancel = None) -> tuple[NDArray[np.float64], float]:
    """Measure the landing marker with the rig, the target covered meanwhile: the mean of the
    tracked points over MEASURE_S near their median (the marker is the only lit source near the
    ground), in link1, and joint 1's angle meanwhile (rad: the mean of the arm's readings after
    each read of the rig, the angle that link1 is at); NaN when the rig does not see it.
    Afterwards the marker goes and the target is uncovered (in a simulated world; on hardware the
    operator does both)."""
    lit = world.lit()
    if lit.get("target"):
        world.light("target", False)
    joint1: list[float] = []
    try:
        pump(world.clock, world.rig, 0.05, step_s=0.01, cancel=cancel)  # the tracker confirms the new marker
        since = newest_t(world.rig)
        joint1.append(float(world.arm.state().q[0]))
        pump(
            world.clock,
            world.rig,
            MEASURE_S,
            step_s=0.01,
            cancel=cancel,
            on_read=lambda: joint1.append(float(world.arm.state().q[0])),
        )
        frames = world.rig.tracked_since(since)
    finally:
        world.remove_landing_marker()
        if lit.get("target"):
            world.light("target", True)
    seen = [f.position[f.visible] for f in frames if f.visible.any()]
    if not seen:
        return np.full(3, np.nan), float("nan")
    points = np.concatenate(seen)
    center = np.median(points, axis=0)
    near = points[np.linalg.norm(points - center, axis=1) < 0.05]
    return near.mean(axis=0), float(np.mean(joint1))
