"""The MuJoCo world's devices as drivers named in a settings file, as real hardware's would be:

    "arm_driver": "wiithrow.app.worlds.mujoco.drivers:arm",
    "gripper_driver": "wiithrow.app.worlds.mujoco.drivers:gripper",
    "remotes_driver": "wiithrow.app.worlds.mujoco.drivers:remotes"

(`examples/mujoco_settings.json`), so that `wiithrow serve --settings` runs the session and the
dashboard over MuJoCo through `wiithrow.app.worlds.hardware.HardwareWorld`, exactly as over a
real arm. The devices of one clock share one `MujocoLab` (one physical world per clock: `lab_for`),
built from the settings the first factory is given. The remotes are simulated Wiimotes behind the
real driver, speaking HID bytes, that look at the lab's LEDs in the true link1 frame.
"""

from __future__ import annotations

import threading
import weakref
from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray

from wiithrow.app.rig.simulated import simulated_drivers
from wiithrow.app.settings import Settings
from wiithrow.app.worlds.base import SOURCES
from wiithrow.app.worlds.held import HeldSources
from wiithrow.app.worlds.mujoco.arm_servo import position_feedforward
from wiithrow.app.worlds.mujoco.devices import MujocoArm, MujocoGripper, MujocoPositionArm
from wiithrow.app.worlds.mujoco.lab import MujocoLab
from wiithrow.clock import Clock, SystemClock
from wiithrow.robot import ArmModel
from wiithrow.vision.camera import WiimoteCamera
from wiithrow.vision.wiimote.device import WiimoteDriver

_LABS: weakref.WeakKeyDictionary[object, MujocoLab] = weakref.WeakKeyDictionary()
_LOCK = threading.Lock()


def lab_for(clock: Clock, settings: Settings, *, seed: int | None = None, served: bool = True) -> MujocoLab:
    """The world on `clock` (built from `settings` the first time; later settings are ignored).
    `served`: built for the drivers of a `HardwareWorld` (a lab's operator put the target down at
    `mujoco.target_base`, on either clock: on a simulated one for the tests of the hardware path);
    `MujocoWorld` builds it first, saying whether it is (a real-time one: the demo's operator)."""
    with _LOCK:
        lab = _LABS.get(clock)
        if lab is None:
            lab = _LABS[clock] = MujocoLab(settings, clock, seed=seed)
            if served:
                lab.place_target(settings.mujoco.target_base)
                lab.set_led("target", True)  # the operator put the target down
        return lab


def lab_of(clock: Clock) -> MujocoLab | None:
    """The world on `clock`, if the drivers built one (what a test or a benchmark of the hardware path
    reads the truth from: where the ball came down)."""
    with _LOCK:
        return _LABS.get(clock)


def arm(model: ArmModel, clock: Clock, settings: Settings) -> MujocoArm | MujocoPositionArm:
    """The arm driver (`arm_driver`): the velocity-mode host over a torque or velocity servo, the
    position-mode host over a position servo (`arm_servo`), its setpoints with the feed-forward the
    settings name (`mujoco.feedforward`)."""
    lab = lab_for(clock, settings)
    gains = lab.built.servo
    assert gains is not None
    if gains.kind != "position":
        return MujocoArm(model, clock, lab)
    rotor = lab.model.dof_armature[lab.built.joint_dof].copy()
    feedforward = position_feedforward(settings.mujoco.feedforward, gains, model, rotor)
    return MujocoPositionArm(model, clock, lab, feedforward)


def gripper(model: ArmModel, clock: Clock, settings: Settings) -> MujocoGripper:
    """The hand (`gripper_driver`)."""
    return MujocoGripper(lab_for(clock, settings))


def remotes(
    cameras: Sequence[WiimoteCamera],
    clock: Clock,
    settings: Settings,
    *,
    rng: np.random.Generator | None = None,
    held: HeldSources | None = None,
) -> list[WiimoteDriver]:
    """One simulated remote per camera behind the real driver (`remotes_driver`), looking at the
    lab's LEDs (the IR sources of `wiithrow.app.worlds.base.SOURCES`; the hand's beacons are not
    in this world) and then at what a simulated person holds in front of the rig (`held`, the
    `MujocoWorld`'s: a wand)."""
    lab = lab_for(clock, settings)

    def sources(t: float) -> NDArray[np.float64] | tuple[tuple[float, float, float], ...]:
        if held is not None and held.holding:
            return np.vstack([lab.leds_in_link1(SOURCES, t), held(t)])
        return lab.led_rows_in_link1(SOURCES, t)  # at the report's time; plain rows: nothing to convert per report

    s = settings
    drivers, _ = simulated_drivers(
        cameras,
        sources,
        clock,
        rng if rng is not None else np.random.default_rng(np.random.SeedSequence([s.mujoco.seed, 2])),
        sigma_px=s.noise.pixel_sigma_px,
        realtime=isinstance(clock, SystemClock),
        ir_format=s.rig.ir_format,
        sensitivity=s.rig.sensitivity,
    )
    return drivers
