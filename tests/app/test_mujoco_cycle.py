"""The MuJoCo world's compiled servo cycle (`app/worlds/mujoco/cycle.py`) against the per-period
Python controller it replaces: the arm driver's velocity-mode law run compiled, many periods at a
time, gives the very motion (to the bit) and the very ball events that the driver's own
`VelocityModeArm._control`, called by the lab once per period, gives."""

from __future__ import annotations

import numpy as np

from wiithrow.app.settings import Settings
from wiithrow.app.worlds.mujoco.devices import MujocoArm, MujocoGripper
from wiithrow.app.worlds.mujoco.lab import MujocoLab
from wiithrow.clock import SimClock
from wiithrow.robot import load_arm
from wiithrow.throwing import TRAINING_AREA, plan_throw, solve_throw


def throw_in(lab: MujocoLab, clock: SimClock, arm: MujocoArm, chunks: np.random.Generator | None) -> None:
    """Move to the start of a fast throw, grip, throw, open at the release, run 1.5 s more; the
    clock moves 1 ms at a time, or by random chunks of 1-30 ms (`chunks`)."""
    model = arm.arm_model
    corner = np.array([TRAINING_AREA.x[1], TRAINING_AREA.z[1]])
    plan = plan_throw(model, solve_throw(model, corner), float(corner[1]), q1=0.0)
    hand = MujocoGripper(lab)

    def run(seconds: float) -> None:
        end = clock.now() + seconds
        while clock.now() < end - 1e-9:
            step = 0.001 if chunks is None else 0.001 * int(chunks.integers(1, 31))
            clock.advance(min(step, end - clock.now()))
            lab.advance()

    arm.command_position(plan.trajectory.positions[0])
    run(3.0)
    hand.close()
    run(0.2)
    arm.command_trajectory(plan.trajectory)
    run(plan.release_time)
    hand.open()
    run(1.5)


def test_the_compiled_law_moves_the_arm_as_the_per_period_controller_does():
    settings = Settings()
    model = load_arm("pa10")
    runs = []
    for compiled in (True, False):
        clock = SimClock()
        lab = MujocoLab(settings, clock)
        arm = MujocoArm(model, clock, lab)
        if not compiled:
            lab.attach_host(arm._control)  # the driver's own controller, once per period from Python
        throw_in(lab, clock, arm, np.random.default_rng(3) if compiled else None)
        runs.append((lab, arm))
    (fast, fast_arm), (slow, slow_arm) = runs
    assert fast.t == slow.t
    for a, b in ((fast.data.qpos, slow.data.qpos), (fast.data.qvel, slow.data.qvel)):
        np.testing.assert_array_equal(a, b)
    np.testing.assert_array_equal(fast.servo.integral, slow.servo.integral)
    np.testing.assert_array_equal(fast_arm.last_command, slow_arm.last_command)
    assert fast.servo.saturated_steps == slow.servo.saturated_steps
    ev, ref = fast.events, slow.events
    # the ball left and came down, at the same steps, where the per-period run saw it
    assert ref.released_at is not None and ref.touchdown_at is not None and ref.touchdown is not None
    assert (ev.opened_at, ev.released_at, ev.touchdown_at) == (ref.opened_at, ref.released_at, ref.touchdown_at)
    np.testing.assert_array_equal(ev.touchdown, ref.touchdown)
    np.testing.assert_array_equal(ev.release_velocity, ref.release_velocity)
    assert ev.path_t == ref.path_t and len(ev.path_t) > 50
    np.testing.assert_array_equal(np.array(ev.path), np.array(ref.path))
