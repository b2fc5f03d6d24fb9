"""The real world: Wiimotes found by hidapi on link1, and the real arm through its driver.

Owns `HardwareWorld`, the counterpart of `wiithrow.app.worlds.simulated.SimWorld` that `wiithrow serve` runs the
session and the dashboard on, and `load_arm_driver`, which builds the arm from the settings'
`arm_driver` ("module:factory"; `factory(model, clock)` returns a `wiithrow.robot.interface.Arm`). Without
a driver the arm is a `robot.ParkedArm`: the operator parks the real arm at its home pose (or the
pose given), the rig tracks markers in link1 placed by that pose, and every motion is refused
with a message that says why.

IR sources on real hardware are real: the target is an IR source the operator places (it cannot be
moved from here), and the truth the simulation knows (where the sources are) is unknown, NaN.
The calibration LED in the hand is switched by the driver when it can (`set_marker_led(on)`),
otherwise it is the operator's to light.
"""

from __future__ import annotations

import importlib
from collections.abc import Sequence

import numpy as np
from numpy.typing import ArrayLike, NDArray

from wiithrow.app.errors import AppError
from wiithrow.app.rig.hardware import hardware_drivers
from wiithrow.app.rig.stream import RigStream
from wiithrow.app.settings import Settings
from wiithrow.app.worlds.base import SOURCES, RigWorld, nominal_cameras
from wiithrow.clock import SystemClock
from wiithrow.robot import Arm, ArmModel, ParkedArm, load_arm
from wiithrow.vision import StereoCalibration
from wiithrow.vision.wiimote.device import WiimoteDriver


def load_arm_driver(spec: str, model: ArmModel, clock: SystemClock) -> Arm:
    """The arm named by `spec` ("package.module:factory"), built as factory(model, clock).

    Raises AppError saying what is wrong: a malformed spec, a module that cannot be imported, a
    missing factory, or a result that does not implement `wiithrow.robot.interface.Arm`."""
    module_name, _, attr = spec.partition(":")
    if not module_name or not attr:
        raise AppError(f"arm_driver must be 'module:factory', got {spec!r}")
    try:
        module = importlib.import_module(module_name)
    except ImportError as exc:
        raise AppError(f"arm_driver {spec!r}: cannot import {module_name!r} ({exc})") from exc
    factory = getattr(module, attr, None)
    if not callable(factory):
        raise AppError(f"arm_driver {spec!r}: {module_name} has no callable {attr!r}")
    arm = factory(model, clock)
    if not isinstance(arm, Arm):
        raise AppError(
            f"arm_driver {spec!r} returned a {type(arm).__name__}, which does not implement "
            "wiithrow.robot.interface.Arm (state, command_position, command_trajectory, stop, is_moving, "
            "wait_until_idle)"
        )
    return arm


class HardwareWorld(RigWorld):
    """The real remotes and arm (see the module docstring).

    `drivers`: the remotes' drivers (default: the first `settings.rig.count` Wiimotes hidapi finds);
    `parked_q`: the pose of an arm without a driver (default: its home pose).
    """

    simulated = False

    def __init__(
        self,
        settings: Settings | None = None,
        *,
        calibration: StereoCalibration | None = None,
        drivers: Sequence[WiimoteDriver] | None = None,
        parked_q: ArrayLike | None = None,
    ) -> None:
        self.settings = s = settings or Settings()
        self.clock = SystemClock()
        self.arm_model = load_arm(s.arm, marker_offset=s.marker_offset_m, ball_offset=s.ball.offset_m)
        if s.arm_driver:
            self.arm = load_arm_driver(s.arm_driver, self.arm_model, self.clock)
        else:
            self.arm = ParkedArm(self.arm_model.home if parked_q is None else parked_q, self.clock)
        self.cameras = nominal_cameras(s.rig)
        if drivers is None:
            drivers = hardware_drivers(
                s.rig.count, self.clock, sensitivity=s.rig.sensitivity, ir_format=s.rig.ir_format
            )
        if len(drivers) != len(self.cameras):
            raise AppError(f"{len(drivers)} remote(s) for a rig of {len(self.cameras)} cameras (settings rig.count)")
        self.drivers = list(drivers)
        self.rig = RigStream(self.drivers)
        self.calibration = None
        if calibration is not None:
            self.set_calibration(calibration)
        self._lit = dict.fromkeys(SOURCES, False)

    # -- IR sources -----------------------------------------------------------------------------

    def light(self, name: str, on: bool = True, position_base: ArrayLike | None = None) -> None:
        """The hand's calibration LED through the driver if it can switch it; other sources are
        real objects the operator places, not something to switch or move from here."""
        if name not in SOURCES:
            raise ValueError(f"unknown IR source {name!r}; the world has {SOURCES}")
        if name == "marker":
            switch = getattr(self.arm, "set_marker_led", None)
            if callable(switch):
                switch(bool(on))
            self._lit[name] = bool(on)
            return
        if position_base is not None or on:
            raise AppError(
                f"on real hardware the {name} is an IR source you place; it cannot be placed or lit from here"
            )
        self._lit[name] = False

    def lit(self) -> dict[str, bool]:
        return dict(self._lit)

    def source_positions_base(self, q: ArrayLike | None = None) -> NDArray[np.float64]:
        """Unknown on real hardware: NaN (len(SOURCES), 3). The rig measures what there is."""
        return np.full((len(SOURCES), 3), np.nan)
