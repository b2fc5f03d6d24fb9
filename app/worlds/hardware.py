"""The real world: Wiimotes on link1, the real arm and hand through their drivers.

Owns `HardwareWorld`, the counterpart of `wiithrow.app.worlds.simulated.SimWorld` that `wiithrow serve` runs the
session and the dashboard on, and the loading of its drivers from the settings, each a
"module:factory" (`load_driver`):

* `arm_driver`: `factory(model, clock)` or `factory(model, clock, settings)` returns a
  `wiithrow.robot.interface.Arm`. Without one the arm is a `robot.ParkedArm`: the operator parks
  the real arm at its home pose (or the pose given), the rig tracks markers in link1 placed by
  that pose, and every motion is refused with a message that says why;
* `gripper_driver`: `factory(model, clock, settings)` returns a `wiithrow.robot.gripper.Gripper`,
  the hand that lets the ball go. Without one a throw is refused;
* `remotes_driver`: `factory(cameras, clock, settings)` returns one `WiimoteDriver` per camera.
  Without one, the Wiimotes hidapi finds. A world given its marker `source` (the markers another
  host tracks: `wiithrow.app.worlds.remote.markers_from`) has no remote and no driver of its own.

A spec is imported and called like a Python import: a settings file runs the code it names, so
it is trusted input that must come from its user (docs/bring-up/settings.md, "Settings files run code"). Each
driver loaded is reported (`LoadedDriver`: the spec and the module's file) before its factory
runs; `wiithrow serve` prints them.

The MuJoCo world's devices load this way (`wiithrow.app.worlds.mujoco.drivers`), so `wiithrow serve`
runs over MuJoCo exactly as over real hardware. A hand may offer more than `Gripper`: a simulated
one that can say where the ball is (`ball_position()`) lets the dashboard draw it, and one whose
world has a simulated operator (`landing_measured()`) is told when the landing marker was measured,
and one that can put a surface down (`place_surface(point)`) is given each training target's.

IR sources on real hardware are real: the target is an IR source the operator places (it cannot be
moved from here), and the truth the simulation knows (where the sources are) is unknown, NaN.
The calibration LED in the hand is switched by the driver when it can (`set_marker_led(on)`),
otherwise it is the operator's to light.
"""

from __future__ import annotations

import importlib
import inspect
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from wiithrow.app.errors import AppError
from wiithrow.app.rig.hardware import hardware_drivers
from wiithrow.app.rig.source import MarkerSource
from wiithrow.app.rig.stream import RigStream
from wiithrow.app.settings import Settings
from wiithrow.app.worlds.base import SOURCES, RigWorld, nominal_cameras
from wiithrow.clock import SystemClock
from wiithrow.robot import Arm, ArmModel, ParkedArm
from wiithrow.robot.gripper import Gripper
from wiithrow.vision import StereoCalibration
from wiithrow.vision.wiimote.device import WiimoteDriver


@dataclass(frozen=True)
class LoadedDriver:
    """A driver named by the settings: its key (`arm_driver`), its spec ("module:factory") and
    the file its module was imported from (what ran: a settings file names code to run)."""

    key: str
    spec: str
    file: str

    def __str__(self) -> str:
        return f"{self.key} {self.spec} from {self.file}"


#: Told of each driver once its module is imported, before its factory runs.
OnLoad = Callable[[LoadedDriver], None]


def load_driver(spec: str, key: str, *args: Any, optional: tuple[Any, ...] = (), on_load: OnLoad | None = None) -> Any:
    """What the factory named by `spec` ("package.module:factory", the settings' `key`) returns for
    `*args`, and also `*optional` when its signature takes them; `on_load` is told which module
    file it came from before the factory runs. AppError saying what is wrong: a malformed spec, a
    module that cannot be imported, a missing factory."""
    module_name, _, attr = spec.partition(":")
    if not module_name or not attr:
        raise AppError(f"{key} must be 'module:factory', got {spec!r}")
    try:
        module = importlib.import_module(module_name)
    except ImportError as exc:
        raise AppError(f"{key} {spec!r}: cannot import {module_name!r} ({exc})") from exc
    factory: Callable[..., Any] | None = getattr(module, attr, None)
    if not callable(factory):
        raise AppError(f"{key} {spec!r}: {module_name} has no callable {attr!r}")
    if on_load is not None:
        on_load(LoadedDriver(key, spec, getattr(module, "__file__", None) or f"{module_name} (no file: built in)"))
    try:
        inspect.signature(factory).bind(*args, *optional)
    except (TypeError, ValueError):  # it takes only the required arguments
        return factory(*args)
    return factory(*args, *optional)


def load_arm_driver(
    spec: str,
    model: ArmModel,
    clock: SystemClock,
    settings: Settings | None = None,
    *,
    on_load: OnLoad | None = None,
) -> Arm:
    """The arm named by `spec`, built as factory(model, clock) or factory(model, clock, settings).

    Raises AppError saying what is wrong (see `load_driver`), or for a result that does not
    implement `wiithrow.robot.interface.Arm`."""
    arm = load_driver(spec, "arm_driver", model, clock, optional=(settings or Settings(),), on_load=on_load)
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
    `parked_q`: the pose of an arm without a driver (default: its home pose); `on_load`: told of
    each driver the settings name once its module is imported, before its factory runs (`wiithrow
    serve` prints them); `loaded` lists them afterwards.
    """

    simulated = False

    def __init__(
        self,
        settings: Settings | None = None,
        *,
        calibration: StereoCalibration | None = None,
        drivers: Sequence[WiimoteDriver] | None = None,
        parked_q: ArrayLike | None = None,
        on_load: OnLoad | None = None,
        source: MarkerSource | None = None,
        clock: SystemClock | None = None,
    ) -> None:
        self.settings = s = settings or Settings()
        self.clock = clock or SystemClock()
        self.loaded: list[LoadedDriver] = []

        def loaded(driver: LoadedDriver) -> None:
            self.loaded.append(driver)
            if on_load is not None:
                on_load(driver)

        self.arm_model = s.load_arm()
        if s.arm_driver:
            self.arm = load_arm_driver(s.arm_driver, self.arm_model, self.clock, s, on_load=loaded)
        else:
            self.arm = ParkedArm(self.arm_model.home if parked_q is None else parked_q, self.clock)
        if s.gripper_driver:
            gripper = load_driver(s.gripper_driver, "gripper_driver", self.arm_model, self.clock, s, on_load=loaded)
            if not isinstance(gripper, Gripper):
                raise AppError(
                    f"gripper_driver {s.gripper_driver!r} returned a {type(gripper).__name__}, which does not "
                    "implement wiithrow.robot.gripper.Gripper (open, close, state)"
                )
            self.gripper = gripper
        self.cameras = nominal_cameras(s.rig)
        self.calibration = None
        self.drivers: list[WiimoteDriver] = []
        if source is not None:
            if len(source.camera_names) != len(self.cameras):
                raise AppError(
                    f"{len(source.camera_names)} camera(s) send markers for a rig of {len(self.cameras)} (settings rig.count)"
                )
            self.rig: MarkerSource = source
        else:
            self.drivers = self._remotes(drivers, loaded)
            self.rig = RigStream(self.drivers)
            if calibration is not None:
                self.set_calibration(calibration)
        self._lit = dict.fromkeys(SOURCES, False)

    def _remotes(self, drivers: Sequence[WiimoteDriver] | None, loaded: OnLoad) -> list[WiimoteDriver]:
        """The given drivers, else the settings' `remotes_driver`'s (`loaded` is told), else hidapi's remotes."""
        s = self.settings
        if drivers is None and s.remotes_driver:
            drivers = list(load_driver(s.remotes_driver, "remotes_driver", self.cameras, self.clock, s, on_load=loaded))
        if drivers is None:
            drivers = hardware_drivers(
                s.rig.count, self.clock, sensitivity=s.rig.sensitivity, ir_format=s.rig.ir_format
            )
        if len(drivers) != len(self.cameras):
            raise AppError(f"{len(drivers)} remote(s) for a rig of {len(self.cameras)} cameras (settings rig.count)")
        return list(drivers)

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

    def set_surface(self, point_base: ArrayLike) -> None:
        """The surface a training throw comes down on: on hardware the operator's (the training
        target's height); a hand whose world has a simulated operator (`place_surface(point)`) has
        them put it there."""
        place = getattr(self.gripper, "place_surface", None)
        if callable(place):
            place(np.asarray(point_base, dtype=float))

    def remove_landing_marker(self) -> None:
        """The operator takes the marker away; a hand whose world has a simulated operator is told."""
        done = getattr(self.gripper, "landing_measured", None)
        if callable(done):
            done()
