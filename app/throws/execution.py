"""Playing a validated throw in the world: the arm moves, the ball flies, the rig measures where.

Only a `throwing.ValidatedThrow` is executed (the validator is the only way to get one). Steps:

1. check that the throw starts where the arm is (plan it with `q_start` = the arm's state, so that
   the move to the wind-up pose is part of the validated trajectory: nothing else moves the arm);
2. command the throw's trajectory; the hand opens at the release time plus a jitter
   dt ~ N(0, sigma_jitter^2); the ball leaves with the `ball` frame's position and velocity of the
   arm's actual state then (which carries the simulated joint tracking error). The arm's state
   exists at its 1 kHz steps, so the release state is interpolated between the two steps around
   the release instant;
3. the ball flies (gravity and quadratic drag, `wiithrow.throwing.ballistics.fly`) until it comes down
   on the surface: the true target's height (not the measured one the throw was planned for);
4. as in the paper, an IR marker is put where the ball landed (the `landing` source; the target is
   covered meanwhile) and the stereo rig measures it: the mean of the tracked positions over
   `measure_s`, in link1, gives the measured landing (x, z) in the throw plane.

The result keeps the true landing as well as the measured one: the simulation knows both, the
operator only the second.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from wiithrow.app.errors import AppError
from wiithrow.app.rig.waiting import Cancel, Cancelled, is_cancelled, wait_while_moving
from wiithrow.app.worlds import RigWorld
from wiithrow.throwing import Ball, ReleaseState, ValidatedThrow, flight_path, fly, release_state

MEASURE_S = 0.3  # how long the rig looks at the landing marker
START_TOLERANCE_RAD = 0.005  # the throw must start this close to the arm's pose


@dataclass(frozen=True)
class ThrowExecution:
    """What happened in one throw. Positions in `base` unless named otherwise (m)."""

    release: ReleaseState
    landing_base: NDArray[np.float64]  # where the ball came down through the landing height
    landing_link1: NDArray[np.float64]
    measured_link1: NDArray[np.float64]  # the rig's measurement of the landing marker (NaN if unseen)
    flight_base: NDArray[np.float64] = field(repr=False)  # (N, 3) the ball's path
    flight_times: NDArray[np.float64] = field(repr=False)
    q1: float = 0.0
    t_release: float = 0.0  # on the world's clock

    @property
    def measured_xz(self) -> NDArray[np.float64]:
        """The measured landing (x, z) in the throw plane (link1)."""
        return self.measured_link1[[0, 2]]


def ball_of(world: RigWorld) -> Ball:
    b = world.settings.ball
    return Ball(radius=b.radius_m, mass=b.mass_kg, drag_coefficient=b.drag_coefficient, air_density=b.air_density)


def execute_throw(
    world: RigWorld,
    throw: ValidatedThrow,
    rng: np.random.Generator,
    *,
    release_jitter_s: float | None = None,
    measure: bool = True,
    cancel: Cancel = None,
    surface_height: float | None = None,
) -> ThrowExecution:
    """Play `throw` in `world` (see the module docstring). Raises AppError if cancelled before the
    release (the arm is stopped); after the release the throw completes and brakes by itself.

    The ball comes down on the real surface: `surface_height` (m, base), by default the lit
    target's true height, else the height the throw was planned for. (The plan uses the target's
    *measured* height; a miscalibrated rig measures it wrong, the floor does not move.)"""
    if not isinstance(throw, ValidatedThrow):
        raise AppError("only a validated throw is executed: plan it with the throw planner (it validates)")
    arm, model = world.arm, world.arm_model
    jitter = world.settings.noise.release_jitter_s if release_jitter_s is None else release_jitter_s

    _wait_idle(world, cancel)
    gap = np.abs(throw.start_pose - arm.state().q)
    if np.any(gap > START_TOLERANCE_RAD):
        j = int(np.argmax(gap))
        raise AppError(
            f"the throw starts {gap[j]:.3f} rad from the arm at joint {model.joint_names[j]}: plan it from "
            "the arm's current pose (q_start), so the whole motion is validated"
        )
    _check_cancel(world, cancel)

    t_command = world.clock.now()
    arm.command_trajectory(throw.trajectory)
    t_release = t_command + throw.release_time + (rng.normal(0.0, jitter) if jitter > 0 else 0.0)
    before = _state_at_step_before(world, t_release, cancel)
    world.advance(0.001)
    after = arm.state()
    alpha = 0.0 if after.t == before.t else (t_release - before.t) / (after.t - before.t)
    q = before.q + alpha * (after.q - before.q)
    dq = before.dq + alpha * (after.dq - before.dq)
    release = release_state(model, q, dq, t_release)

    ball = ball_of(world)
    if surface_height is None:
        target = world.source_position_base("target")
        surface_height = float(target[2]) if np.isfinite(target).all() else float(throw.landing_height)
    landing_height = float(surface_height)
    landing = fly(release.position, release.velocity, landing_height, ball)
    times, path = flight_path(release.position, release.velocity, landing_height, ball)
    q1 = float(throw.q1)
    landing_link1 = world.base_to_link1(landing.position, _with_q1(model.home, q1))[0]

    _wait_idle(world, None)  # the follow-through brakes to rest
    measured = _measure_landing(world, landing.position) if measure else np.full(3, np.nan)
    return ThrowExecution(
        release, np.asarray(landing.position, float), landing_link1, measured, path, times, q1, t_release
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


def _with_q1(q: NDArray[np.float64], q1: float) -> NDArray[np.float64]:
    q = np.array(q, dtype=float)
    q[0] = q1
    return q


def _check_cancel(world: RigWorld, cancel: Cancel) -> None:
    if is_cancelled(cancel):
        world.arm.stop()
        raise AppError("the throw was stopped before the release; the arm brakes to rest")


def _wait_idle(world: RigWorld, cancel: Cancel, timeout_s: float = 20.0) -> None:
    """Read the rig while the arm moves; a Stop before the release stops the arm (AppError)."""
    try:
        idle = wait_while_moving(
            world.arm, world.clock, world, timeout_s=timeout_s, step_s=0.01, poll_step_s=0.001, cancel=cancel
        )
    except Cancelled:
        _check_cancel(world, cancel)
        raise
    if not idle:
        world.arm.stop()
        raise AppError(f"the arm did not come to rest within {timeout_s:.0f} s")


def _state_at_step_before(world: RigWorld, t: float, cancel: Cancel):
    """Run the world to the arm's last 1 ms step at or before t and return the state there."""
    while world.clock.now() < t - 0.001:
        _check_cancel(world, cancel)
        world.advance(min(0.01, t - 0.001 - world.clock.now()))
    step = math.floor(t * 1000.0 + 1e-9) / 1000.0
    if world.clock.now() < step:
        world.advance(step - world.clock.now())
    return world.arm.state()


def _measure_landing(world: RigWorld, landing_base: NDArray[np.float64]) -> NDArray[np.float64]:
    """Put the landing marker down (the target covered meanwhile) and average the rig's
    measurement of it over MEASURE_S; NaN when the rig does not see it."""
    lit = world.lit()
    world.light("target", False)
    world.light("landing", True, landing_base)
    try:
        world.advance(0.05)  # the tracker confirms the new marker
        frames = world.advance(MEASURE_S)
    finally:
        world.light("landing", False)
        if lit["target"]:
            world.light("target", True)
    seen = [f.position[f.visible] for f in frames if f.visible.any()]
    if not seen:
        return np.full(3, np.nan)
    points = np.concatenate(seen)
    # the landing marker is the only lit source near the ground: take the points near their median
    center = np.median(points, axis=0)
    near = points[np.linalg.norm(points - center, axis=1) < 0.05]
    return near.mean(axis=0)
