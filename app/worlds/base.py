"""What every world shares, simulated or real: `RigWorld`, the IR sources, the nominal rig.

A world is the arm (an `wiithrow.robot.Arm` with its `ArmModel`), the rig of Wiimotes on link 1
(its `rig`: a `wiithrow.app.rig.source.MarkerSource`, given when the world is built: this host's
remotes, or the markers another host tracks) and its calibration, one clock, and the IR sources the
remotes can see. `wiithrow.app.worlds.simulated.SimWorld` simulates all of it;
`wiithrow.app.worlds.hardware.HardwareWorld` drives the real arm and remotes. The session, the
calibration, the alignment and the dashboard only use what is here, so the code that drives a
simulated world is the code that drives the hardware.

Physical layout (docs/simulation.md, "The default world"; numbers in `wiithrow.app.settings`):
the arm's base at the origin of `base`, z up; the rig's cameras fixed in `link1`, so they turn
with joint 1. IR sources, each at a fixed index (NaN while it is off), so that the simulated
cameras keep a source in the same dot slot as the real camera's blob tracker does: the
calibration LED in the hand (`marker` frame), the target, the marker put where a ball landed, and
two beacons on the hand for the mono method.

Frames: points go between `base` and `link1` at the arm's joint state q,

    p_link1 = R_1^T (p_base - o_1),       (R_1, o_1) = placement of link1 in base at q.
"""

from __future__ import annotations

import abc
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Protocol

import numpy as np
from numpy.typing import ArrayLike, NDArray

from wiithrow.app.errors import AppError
from wiithrow.app.rig.source import MarkerSource
from wiithrow.app.rig.waiting import Cancel, pump
from wiithrow.app.settings import RigSettings, Settings
from wiithrow.app.worlds.grip import close_on_ball, close_time_s
from wiithrow.clock import SimClock, SystemClock
from wiithrow.robot import Arm, ArmModel, load_arm
from wiithrow.robot.gripper import Gripper
from wiithrow.throwing import Ball, ReleaseState
from wiithrow.vision import StereoCalibration
from wiithrow.vision.camera import WiimoteCamera
from wiithrow.vision.dlt import CalibratedCamera
from wiithrow.vision.rig import stereo_rig
from wiithrow.vision.wand.frames import FrameFit, transform_calibration

#: The IR sources of the world, in index order (the first four lit ones are what a camera reports).
SOURCES = ("marker", "target", "landing", "beacon_a", "beacon_b")
#: Distance between the two hand beacons of the mono method (m), along the marker frame's x axis.
BEACON_DISTANCE_M = 0.15


#: What a world may be given to read instead of its own remotes' rig: a marker source made from the
#: world once built (`wiithrow.app.worlds.remote.simulated_loopback`).
MarkersOf = Callable[["RigWorld"], MarkerSource]

#: Why a throw is refused without a hand.
NO_GRIPPER = (
    "throwing needs a gripper driver to let the ball go (the settings' gripper_driver, 'module:factory'); "
    "Preview throw shows the plan"
)


@dataclass(frozen=True)
class BallFlight:
    """What a simulated world knows of a thrown ball (positions in `base`, m; times on its clock):
    the `release` (the ball's state as it left the hand, the arm's joints then), where it first
    came down (`landing_base`: the kinematic world's ball centre through the surface's height, the
    MuJoCo world's first contact point), and its `path` (N, 3) at `times` (N,), for drawing.
    `spin` (3,) rad/s where the world has one."""

    release: ReleaseState
    landing_base: NDArray[np.float64]
    times: NDArray[np.float64] = field(repr=False)
    path: NDArray[np.float64] = field(repr=False)
    spin: NDArray[np.float64] | None = None


class WandWaver(Protocol):
    """A simulated person who waves a calibration wand in front of the rig (a world's
    `wand_waver`; None on hardware, where a person does it unasked)."""

    def wave_wand(self, seconds: float, wand_length_m: float, rng: np.random.Generator) -> object:
        """Wave a wand `wand_length_m` long for `seconds` from now (returns its path)."""

    def put_away(self) -> None:
        """Put the wand (and anything else held in front of the rig) away."""


class LandingMarker(Protocol):
    """A simulated operator who puts the IR marker where a ball came down, the target covered (a
    world's `landing_marker`; None on hardware, where the operator does it before *Measure landing*)."""

    def place_landing_marker_at(self, landing_base: NDArray[np.float64]) -> bool:
        """Put the marker at `landing_base` (m; with the operator's placement error where the world
        models one); False when that is not possible (an unknown landing)."""


def source_index(name: str) -> int:
    """The fixed index of IR source `name` (ValueError naming the sources for an unknown one)."""
    try:
        return SOURCES.index(name)
    except ValueError:
        raise ValueError(f"unknown IR source {name!r}; the world has {SOURCES}") from None


def check_calibration_fits(
    calibration: StereoCalibration,
    *,
    remotes: int,
    frame: str | None = None,
    arm: str | None = None,
    source: str = "the calibration",
) -> None:
    """AppError unless `calibration` has one camera per remote, when `frame` is given is in that
    frame (the rig on the arm is tracked in link1; a command that labels its points with the
    calibration's frame takes any), and when `arm` is given was not made on another arm (its
    `arm`: a link1 is one arm's; a calibration that does not say is taken to be this arm's,
    `unknown_arm_warning`). `source`: how the error names the calibration (its file)."""
    if arm is not None and calibration.arm is not None and calibration.arm != arm:
        raise AppError(
            f"{source} was made on arm {calibration.arm!r} (frame {calibration.frame}), and this arm is {arm!r}: "
            "its link1 is another arm's; calibrate this rig on this arm (`wiithrow calibrate --robot`)"
        )
    if len(calibration.cameras) != remotes:
        raise AppError(
            f"the calibration has {len(calibration.cameras)} cameras and the rig {remotes} remotes: "
            "calibrate this rig (one camera per remote, in the order of their LEDs)"
        )
    if frame is not None and calibration.frame != frame:
        raise AppError(
            f"the calibration is in frame {calibration.frame!r}, but the rig on the arm is tracked in {frame}: "
            f"use a calibration made in {frame} (`wiithrow calibrate --robot`, or --frame {frame} for points "
            f"measured in {frame})"
        )


def unknown_arm_warning(calibration: StereoCalibration, arm: str, source: str = "the calibration") -> str | None:
    """The warning for a calibration in link1 that does not say which arm it was made on (a file
    from before the arm was recorded, or one made from points measured in link1): it is taken to
    be `arm`'s. None when it says, or its frame is no arm's."""
    if calibration.arm is not None or calibration.frame != "link1":
        return None
    return (
        f"{source} does not say which arm it was made on (written before the arm was recorded, or from points): "
        f"it is taken to be arm {arm!r}'s link1"
    )


def nominal_cameras(rig: RigSettings) -> list[WiimoteCamera]:
    """The rig's cameras as the settings place them, in `link1`."""
    return stereo_rig(
        center=rig.center,
        baseline=rig.baseline,
        count=rig.count,
        converge_m=rig.converge_m,
        pitch_down_rad=np.deg2rad(rig.pitch_down_deg),
        focal_px=rig.focal_px,
        center_px=rig.center_px,
        frame="link1",
    )


def on_link1(calibration: StereoCalibration, cameras: Sequence[WiimoteCamera]) -> StereoCalibration:
    """The calibration in link1, where the rig's tracking meets the arm.

    A calibration in link1 (the robot's, a wand calibration with --frame robot) is used as it is.
    One in the frame of the rig's first camera (a wand calibration's default) is placed by that
    camera's nominal pose (x_cam = R0 X + t0, from the settings):

        X_link1 = R0^T X_cam0 - R0^T t0,

    exact in simulation (the simulated remotes sit at the nominal poses), as good as the remote's
    placement on real hardware (aim the arm with a calibration made --frame robot). AppError for
    any other frame (an L-frame's has no known place on the robot).
    """
    if calibration.frame == "link1":
        return calibration
    first = cameras[0]
    if calibration.frame != first.name:
        raise AppError(
            f"a calibration in frame {calibration.frame!r} cannot be placed on the robot: use one in link1 "
            f"(calibrate --wand --frame robot) or in the first camera's frame ({first.name})"
        )
    placed = transform_calibration(calibration, FrameFit("link1", first.R.T, -first.R.T @ first.t, np.zeros(0), 1.0))
    return StereoCalibration(
        placed.cameras, "link1", placed.loo_error_m, {**placed.meta, "placed_by": f"the nominal pose of {first.name}"}
    )


class RigWorld(abc.ABC):
    """What every world shares, simulated or real: an arm with its model, the rig on link1 (a
    `MarkerSource`) and its calibration, one clock, and the frames between `base` and `link1`.

    Subclasses set `settings`, `clock`, `arm_model`, `arm`, `rig`, `calibration` and `cameras`
    (the nominal cameras, which name the rig's cameras) and say how IR sources are lit (`light`,
    `lit`, `source_positions_base`).
    """

    #: True when the arm, the remotes and the ball are simulated (so the truth is known).
    simulated = False
    #: Which world this is, in words, as the commands' first line and the dashboard say it.
    title = "hardware (the drivers the settings name)"
    settings: Settings
    clock: SimClock | SystemClock
    arm_model: ArmModel
    arm: Arm
    rig: MarkerSource
    calibration: StereoCalibration | None
    cameras: list[WiimoteCamera]
    #: The hand that lets the ball go (None: no driver, a throw is refused).
    gripper: Gripper | None = None
    #: How long (s) the hand took to close on the ball at the last load that held (None: none yet).
    hand_close_measured_s: float | None = None
    #: What a simulated world offers beyond the hardware's interfaces (None where it does not):
    #: a person who waves a wand for a wand calibration, an operator who marks a landing.
    wand_waver: WandWaver | None = None
    landing_marker: LandingMarker | None = None
    _connected = False

    @property
    def tracks_markers(self) -> bool:
        """True when the rig delivers tracked markers in link1 (calibrated here, or tracked by the
        host the markers come from)."""
        return self.rig.calibrated

    @property
    def arm_connected(self) -> bool:
        """False when the arm has no driver (a `robot.ParkedArm`: it stays put, refuses to move)."""
        return bool(getattr(self.arm, "connected", True))

    def _init_simulated(self, settings: Settings | None, realtime: bool, arm_model: ArmModel | None) -> Settings:
        """A simulated world's settings, clock (simulated, or the system's in real time) and nominal arm."""
        self.settings = s = settings or Settings()
        self.realtime = realtime
        self.clock = SystemClock() if realtime else SimClock()
        self.arm_model = arm_model or load_arm(s.arm, marker_offset=s.marker_offset_m, ball_offset=s.ball.offset_m)
        return s

    # -- running --------------------------------------------------------------------------------

    def connect(self) -> None:
        """Start the remotes' cameras through their drivers."""
        if not self._connected:
            self.rig.connect()
            self._connected = True

    def close(self) -> None:
        if self._connected:
            self.rig.close()
            self._connected = False

    def set_calibration(self, calibration: StereoCalibration) -> None:
        """Track with this calibration from now on (in link1: see `on_link1`). AppError when it does
        not fit this rig (`check_calibration_fits`: one camera per remote, made on this arm) or has a
        frame that cannot be placed."""
        check_calibration_fits(calibration, remotes=len(self.rig.camera_names), arm=self.arm_model.name)
        calibration = on_link1(calibration, self.cameras)
        self.calibration = calibration
        self.rig.set_calibration(calibration.Ps)

    # -- frames ---------------------------------------------------------------------------------

    def base_to_link1(self, points: ArrayLike, q: ArrayLike | None = None) -> NDArray[np.float64]:
        """Points (N, 3) from `base` to `link1` at joint state q (default: the arm's now)."""
        q = self.arm.state().q if q is None else q
        return self.arm_model.to_frame(np.asarray(points, dtype=float).reshape(-1, 3), q, "link1")

    def link1_to_base(self, points: ArrayLike, q: ArrayLike | None = None) -> NDArray[np.float64]:
        """Points (N, 3) from `link1` to `base` at joint state q (default: the arm's now)."""
        q = self.arm.state().q if q is None else q
        return self.arm_model.from_frame(np.asarray(points, dtype=float).reshape(-1, 3), q, "link1")

    # -- IR sources (each world says how they are lit and where they are) ---------------------------

    @abc.abstractmethod
    def light(self, name: str, on: bool = True, position_base: ArrayLike | None = None) -> None:
        """Switch IR source `name` on or off (fixed sources take a position in `base`)."""

    @abc.abstractmethod
    def lit(self) -> dict[str, bool]:
        """Which IR sources are on."""

    @abc.abstractmethod
    def source_positions_base(self, q: ArrayLike | None = None) -> NDArray[np.float64]:
        """Positions (len(SOURCES), 3) in `base` of every IR source at joint state q, NaN for those
        unlit or unknown (on real hardware all of them: the rig measures what there is)."""

    def source_position_base(self, name: str, q: ArrayLike | None = None) -> NDArray[np.float64]:
        """Where source `name` is in `base` (3,), NaN while it is unlit or unknown."""
        return self.source_positions_base(q)[source_index(name)]

    def true_calibration_Ps(self) -> NDArray[np.float64]:
        """The rig's cameras as mounted (C, 3, 4), in link1: in a simulated world the true ones."""
        return np.stack([c.P for c in self.cameras])

    def true_calibration(self) -> StereoCalibration:
        """The mounted cameras as a calibration in link1: in a simulated world, tracking with no
        calibration error."""
        empty = (np.zeros((0, 3)), np.zeros((0, 2)), np.zeros(0), np.zeros(0, bool))
        cameras = tuple(CalibratedCamera(c.P, "true", *empty, name=c.name) for c in self.cameras)
        return StereoCalibration(cameras, "link1", arm=self.arm_model.name)

    def camera_names(self) -> Sequence[str]:
        return [c.name for c in self.cameras]

    # -- the ball (how a throw lets it go and learns where it came down) -------------------------------

    def ball(self) -> Ball:
        """The ball and the air of the settings, as the planner models them."""
        b = self.settings.ball
        return Ball(radius=b.radius_m, mass=b.mass_kg, drag_coefficient=b.drag_coefficient, air_density=b.air_density)

    def load_ball(self, cancel: Cancel = None) -> None:
        """Close the hand on the ball and wait until it holds it (`grip.close_on_ball`: up to
        twice the hand's close time, stated in the settings, else measured at the last load, else
        assumed), reading the rig meanwhile; the close time it took is kept
        (`hand_close_measured_s`). AppError without a hand, or when it did not close on the ball
        in time (put the ball between its jaws first). A simulated world's operator puts the ball
        there (`SimWorld`, the MuJoCo world's lab)."""
        if self.gripper is None:
            raise AppError(NO_GRIPPER)
        close_s, source = close_time_s(self.settings.hand_close_s, self.hand_close_measured_s)

        def wait(seconds: float) -> None:
            pump(self.clock, self.rig, seconds, step_s=min(seconds, 0.01), cancel=cancel)

        self.hand_close_measured_s = close_on_ball(self.gripper, self.clock.now, wait, close_s, source)

    def set_surface(self, point_base: ArrayLike) -> None:
        """The ball will come down on a surface through `point_base` (m): a simulated world that
        models surfaces puts one there (the MuJoCo world's table); the others need nothing."""
        return None

    def after_open(self, cancel: Cancel = None) -> None:
        """The hand was just told to open. A world that computes the ball's flight itself takes the
        release state here (the kinematic world); the others let physics or reality do it."""
        return None

    def await_landing(self, surface_height: float, timeout_s: float = 5.0) -> BallFlight | None:
        """After the release: run until the ball came down and say what it did (simulated worlds);
        None where nobody knows (real hardware: the operator marks the landing)."""
        return None

    def place_landing_marker(self, flight: BallFlight | None) -> bool:
        """Put the IR marker where the ball came down (the target covered) so that the rig can
        measure it; False when that is the operator's job (real hardware: *Measure landing*)."""
        return False

    def remove_landing_marker(self) -> None:
        """The landing was measured: take the marker away and uncover the target."""
        return None

    def ball_position(self) -> NDArray[np.float64] | None:
        """Where the ball is now (m, base) when the world knows it (the MuJoCo world's physics);
        None otherwise (the kinematic world draws it from the plan, hardware does not know)."""
        return None
