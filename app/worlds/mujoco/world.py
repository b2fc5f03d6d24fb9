"""`MujocoWorld`: the whole system in MuJoCo, a physics the planner does not know, reached only
through the interfaces real hardware has.

The arm is the settings' arm in MuJoCo (the PA-10 by default; `drivers.arm`: the host's velocity-mode driver on the lab's servo,
an `wiithrow.robot.interface.Arm`), the hand is `drivers.gripper` (a `wiithrow.robot.gripper.Gripper`),
the remotes are simulated Wiimotes speaking HID bytes behind the real driver (`drivers.remotes`),
looking at the LEDs of the MuJoCo scene from the true link1. These are the very drivers
`wiithrow serve --settings examples/mujoco_settings.json` loads into `HardwareWorld`; this class
adds what only a simulation has: a simulated clock (faster than real time), the truth (where the
ball really came down, the LEDs' true positions), and placing the target.

The arm model the rest of the system uses (`arm_model`) is the nominal URDF's; the world's arm
differs from it by its manufacturing tolerances (`wiithrow.app.worlds.mujoco.model`). After a
throw the lab's simulated operator puts the landing LED where the ball first touched down (with
its placement error) and covers the target; the rig measures it (`measure_marker`), and that
measurement, never the lab's truth, labels and scores throws.

Like the kinematic world it offers a simulated person (`wiithrow.app.worlds.held.HeldSources`,
its `wand_waver`: the remotes also see the wand they wave, for a wand calibration) and a simulated
operator who marks a landing where asked (`place_landing_marker_at`, its `landing_marker`).
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
from numpy.typing import ArrayLike, NDArray

from wiithrow.app.errors import AppError
from wiithrow.app.rig.stream import RigStream
from wiithrow.app.rig.waiting import pump
from wiithrow.app.settings import Settings
from wiithrow.app.worlds.base import SOURCES, BallFlight, RigWorld, nominal_cameras
from wiithrow.app.worlds.grip import BallLost
from wiithrow.app.worlds.held import HeldSources
from wiithrow.app.worlds.mujoco import drivers
from wiithrow.app.worlds.mujoco.lab import LEDS, MujocoLab
from wiithrow.clock import SystemClock
from wiithrow.robot import ArmModel
from wiithrow.throwing import ReleaseState
from wiithrow.vision import StereoCalibration


class MujocoWorld(RigWorld):
    """The MuJoCo world (see the module docstring). `seed` draws the remotes' noise, the hand's
    jitter and the operator's placement; the arm's tolerances come from `settings.mujoco.seed`."""

    simulated = True
    title = "MuJoCo (simulated)"

    def __init__(
        self,
        settings: Settings | None = None,
        *,
        seed: int = 0,
        realtime: bool = False,
        calibration: StereoCalibration | None = None,
        arm_model: ArmModel | None = None,
    ) -> None:
        # the arm its settings name (a shipped one, or one they define: `Settings.load_arm`)
        s = self._init_simulated(settings, realtime, arm_model or (settings or Settings()).load_arm())
        # a real-time world's operator put the target down, as a served one's (`drivers.lab_for`)
        self.lab: MujocoLab = drivers.lab_for(self.clock, s, seed=seed, served=isinstance(self.clock, SystemClock))
        self.arm = drivers.arm(self.arm_model, self.clock, s)
        self.gripper = drivers.gripper(self.arm_model, self.clock, s)
        self.cameras = nominal_cameras(s.rig)
        self.held = HeldSources(self.cameras, self.clock)
        self.wand_waver = self.held
        self.landing_marker = self
        rng = np.random.default_rng(np.random.SeedSequence([seed, 3]))
        self.drivers = drivers.remotes(self.cameras, self.clock, s, rng=rng, held=self.held)
        self.rig = RigStream(self.drivers, calibration.Ps if calibration is not None else None)
        self.calibration = calibration

    @property
    def release_latency_s(self) -> float:
        """The hand's latency now (s, the settings')."""
        return self.lab.settings.mujoco.release_latency_s

    def drift(
        self,
        *,
        release_latency_s: float | None = None,
        ball_mass_kg: float | None = None,
        grip_force_n: float | None = None,
    ) -> None:
        """Change the world mid-run, as `SimWorld.drift`: the hand's latency (s) from its next
        command on (the lab reads `settings.mujoco` at each command); the fingers' grip force (N)
        from now on (`MujocoLab.set_grip_force`: weakened in the wind-up, the ball slips out). The
        ball's mass is compiled into the MuJoCo model: ValueError (build a world with other `ball`
        settings instead)."""
        if ball_mass_kg is not None:
            raise ValueError("the MuJoCo world's ball mass is compiled into its model: build a world with it instead")
        if grip_force_n is not None:
            self.lab.set_grip_force(grip_force_n)
        if release_latency_s is not None:
            if not (math.isfinite(release_latency_s) and 0 <= release_latency_s <= 1.0):
                raise ValueError(f"release latency must be 0-1 s, got {release_latency_s}")
            mujoco = dataclasses.replace(self.lab.settings.mujoco, release_latency_s=float(release_latency_s))
            self.lab.settings = self.lab.settings.replace(mujoco=mujoco)
            self.settings = self.settings.replace(mujoco=mujoco)

    # -- IR sources: the scene's LEDs ----------------------------------------------------------------

    def light(self, name: str, on: bool = True, position_base: ArrayLike | None = None) -> None:
        """The hand's LED, the target (placed on a table of its height) and the landing marker."""
        if name not in SOURCES:
            raise ValueError(f"unknown IR source {name!r}; the world has {SOURCES}")
        if name not in LEDS:
            if on:
                raise AppError(f"the MuJoCo world has no {name} (the mono study's beacons live in the kinematic world)")
            return
        if name == "target" and position_base is not None:
            self.lab.place_target(position_base)
        elif position_base is not None:
            raise AppError(f"the {name} LED is placed by the world, not from here")
        self.lab.set_led(name, on)

    def lit(self) -> dict[str, bool]:
        lit = dict.fromkeys(SOURCES, False)
        lit.update(self.lab.lit)
        return lit

    def source_positions_base(self, q: ArrayLike | None = None) -> NDArray[np.float64]:
        """The LEDs' true positions now (NaN while off; the target also while covered)."""
        positions = self.lab.led_positions()
        return np.array([positions.get(name, np.full(3, np.nan)) for name in SOURCES])

    # -- the ball ----------------------------------------------------------------------------------

    def set_surface(self, point_base: ArrayLike) -> None:
        """The table's top at `point_base` (none on the floor)."""
        self.lab.place_table(point_base)

    def await_landing(self, surface_height: float, timeout_s: float = 5.0) -> BallFlight | None:
        """Run until the ball first touched the floor or the table; its release and that contact
        point, as the lab saw them (the surface height is the world's business here). A ball that
        had left the hand before it opened flies no throw: BallLost at once, nothing waited for. The rig is
        read every 10 ms meanwhile, as each remote reports (the lab watches the ball every step
        itself, so finer reads would only cost)."""
        end = self.clock.now() + timeout_s
        while self.lab.events.touchdown_at is None:
            lost = self.lab.events
            if lost.lost_at is not None and lost.opened_at is None:  # no ball flies: nothing to wait for
                before = None if lost.lost_open_at is None else lost.lost_open_at - lost.lost_at
                raise BallLost(before, "the hand opened")
            if self.clock.now() > end:
                raise AppError(f"the ball did not come down within {timeout_s:.0f} s of the release")
            pump(self.clock, self.rig, 0.01, step_s=0.01)
            self.lab.advance()
        ev = self.lab.events
        assert ev.released_at is not None and ev.touchdown is not None  # touchdown comes after a release
        release = ReleaseState(
            ev.released_at,
            np.asarray(ev.release_q),
            np.asarray(ev.release_dq),
            np.asarray(ev.release_position),
            np.asarray(ev.release_velocity),
        )
        return BallFlight(release, ev.touchdown.copy(), np.array(ev.path_t), np.array(ev.path), ev.release_spin)

    def place_landing_marker(self, flight: BallFlight | None) -> bool:
        """The lab's operator put it down at the touchdown already."""
        return self.lab.events.marker is not None

    def place_landing_marker_at(self, landing_base: NDArray[np.float64]) -> bool:
        """The lab's operator covers the target and puts the landing LED at `landing_base` (with
        their placement error): *Measure landing* in this world."""
        if not np.isfinite(landing_base).all():
            return False
        self.lab.place_landing_marker(np.asarray(landing_base, dtype=float))
        return True

    def remove_landing_marker(self) -> None:
        self.lab.landing_measured()

    def ball_position(self) -> NDArray[np.float64]:
        """Where the ball is now (m, base)."""
        return self.lab.ball_position()
