"""`wiithrow bench following [--settings S.json]`: how the arm follows a throw on the MuJoCo
world's position servo, with each feed-forward of the shipped driver (`mujoco.feedforward`: none,
the velocity term, the inverse dynamics; `wiithrow.robot.feedforward`).

The world is the settings' (a lab's MJCF, `mjcf`), or by default the project's Panda with the PD
servo of a vendor's model (`mujoco.arm_servo` "pd_position": K_d / K_p = 0.09 s, no gravity
compensation). In each, the arm at home at rest is given the throw the simulated operator finds for
the middle of its training area (from home, its prelude included), and its joints are read every
servo period (1 ms) on a simulated clock. Figures per choice: `lag_s`, the shift tau that best
matches q(t) to q_ref(t - tau) over the moving joints (`drivercheck.probes.best_lag`, what
`check-driver` reports), `rms_rad` and `max_rad` (the worst joint's following error), and
`sag_rad`, how far the arm at rest at home stands off its reference before the throw (gravity on
a PD servo without the feed-forward's torque term: g(q) / K_p). Over a torque or velocity servo the feed-forward does not
apply: one row, "amplifier".
"""

from __future__ import annotations

import dataclasses
from typing import Any

import numpy as np

from wiithrow.app.drivercheck.probes import best_lag
from wiithrow.app.errors import AppError
from wiithrow.app.settings import Settings
from wiithrow.app.worlds.mujoco.arm_servo import FEEDFORWARD_CHOICES
from wiithrow.app.worlds.mujoco.world import MujocoWorld
from wiithrow.clock import SimClock
from wiithrow.robot.host_arm import HostArm
from wiithrow.throwing.arm_throwing import training_area
from wiithrow.throwing.limiting import plan_throw
from wiithrow.throwing.operator import solve_throw

#: How long (s) after the throw's end the joints are still read (the follow-through settling).
AFTER_S = 0.3
#: How long (s) the arm stands at home before the throw: five of the PD servo's time constants (K_d / K_p).
SETTLE_S = 0.5


def follow_throw(settings: Settings) -> dict[str, float]:
    """The figures of the module docstring for one world (its settings' feed-forward)."""
    world = MujocoWorld(settings, seed=0)
    clock, host = world.clock, world.arm
    assert isinstance(clock, SimClock) and isinstance(host, HostArm)  # a simulated world's, a host's
    try:
        arm = world.arm_model
        clock.advance(SETTLE_S)  # the host's first setpoints (its feed-forward's) take effect
        if not world.arm.wait_until_idle(5.0):
            raise AppError("the arm did not come to rest at home")
        start = world.arm.state()
        sag = float(np.max(np.abs(start.q - host.reference().q)))
        area = training_area(arm)
        target = np.array([np.mean(area.x), np.mean(area.z)])
        params = solve_throw(arm, target, ball=world.ball())
        traj = plan_throw(
            arm, params, float(target[1]), q1=0.0, ball=world.ball(), q_start=start.q, target=target
        ).trajectory
        t0 = world.clock.now()
        world.arm.command_trajectory(traj)
        times, joints = [], []
        while world.clock.now() < t0 + traj.duration + AFTER_S:
            clock.advance(0.001)
            state = world.arm.state()
            times.append(state.t - t0)
            joints.append(state.q)
        t, q = np.array(times), np.array(joints)
        during = (t >= 0) & (t <= traj.duration)
        reference, _, _ = traj.sample(t[during])
        error = q[during] - reference
        moving = np.ptp(reference, axis=0) > 1e-3
        return {
            "lag_s": best_lag(t[during], q[during], traj, moving),
            "rms_rad": float(np.sqrt(np.mean(error**2, axis=0)).max()),
            "max_rad": float(np.abs(error).max()),
            "sag_rad": sag,
        }
    finally:
        world.close()


def run(quick: bool = False, settings_file: str | None = None) -> dict[str, Any]:
    """Each feed-forward choice's figures (module docstring); `quick` changes nothing (one throw each)."""
    if settings_file is not None:
        settings = Settings.load(settings_file)
    else:
        base = Settings(arm="panda")
        settings = base.replace(mujoco=dataclasses.replace(base.mujoco, arm_servo="pd_position"))
    world = MujocoWorld(settings)
    try:
        servo = world.lab.built.servo
        assert servo is not None
        kind = servo.kind
    finally:
        world.close()
    figures: dict[str, Any] = {"settings": settings_file or "panda, arm_servo pd_position", "servo": kind}
    choices = list(FEEDFORWARD_CHOICES) if kind == "position" else ["amplifier"]
    for choice in choices:
        chosen = settings
        if kind == "position":
            chosen = settings.replace(mujoco=dataclasses.replace(settings.mujoco, feedforward=choice))
        figures[choice] = follow_throw(chosen)
    return figures
