"""The simulated world: the arm, the rig on link 1, the IR sources, all on one clock.

`RigWorld` is what every world shares (running the rig, its calibration, the frames between
`base` and `link1`); `SimWorld` is the simulated one, `wiithrow.app.worlds.hardware.HardwareWorld` the real.

Physical layout (DESIGN.md, "the default simulated world", numbers in `wiithrow.app.settings`): the arm's
base at the origin of `base`, z up; the rig's cameras fixed in `link1`, so they turn with joint 1;
IR sources: the calibration LED in the hand (`marker` frame), the target, the marker put where a
ball landed, and two beacons on the hand for the mono method.

Every IR source has a fixed index (NaN while it is off), so the simulated cameras keep a source in
the same dot slot as the real camera's blob tracker does. The remotes ask for the sources at the
time of each report: their positions in `link1` follow from the arm's state by forward kinematics,

    p_link1 = R_1^T (p_base - o_1),       (R_1, o_1) = placement of link1 in base at the arm's q.

On a `SimClock` the world runs faster than real time: `advance(dt)` moves the clock in 1 ms steps
(the arm integrates at 1 kHz) and reads the remotes at each step; with `realtime=True` it runs on
the system clock and a loop (the dashboard's) calls `poll`.
"""

from __future__ import annotations

import threading
from collections.abc import Sequence

import numpy as np
from numpy.typing import ArrayLike, NDArray

from wiithrow.app.rig.simulated import simulated_drivers
from wiithrow.app.rig.stream import RigStream
from wiithrow.app.settings import RigSettings, Settings
from wiithrow.clock import SimClock, SystemClock
from wiithrow.robot import Arm, ArmModel, SimulatedArm, load_arm
from wiithrow.vision import StereoCalibration
from wiithrow.vision.camera import WiimoteCamera
from wiithrow.vision.rig import stereo_rig
from wiithrow.vision.tracker import TrackedFrame

#: The IR sources of the world, in index order (the first four lit ones are what a camera reports).
SOURCES = ("marker", "target", "landing", "beacon_a", "beacon_b")
#: Distance between the two hand beacons of the mono method (m), along the marker frame's x axis.
BEACON_DISTANCE_M = 0.15


def nominal_cameras(rig: RigSettings) -> list[WiimoteCamera]:
    """The rig's cameras as the settings place them, in `link1`."""
    return stereo_rig(
        center=rig.center,
        baseline=rig.baseline,
        count=rig.count,
        pitch_down_rad=np.deg2rad(rig.pitch_down_deg),
        focal_px=rig.focal_px,
        center_px=rig.center_px,
        frame="link1",
    )


class RigWorld:
    """What every world shares, simulated or real: an arm with its model, the rig on link1 (a
    `RigStream`) and its calibration, one clock, and the frames between `base` and `link1`.

    Subclasses set `settings`, `clock`, `arm_model`, `arm`, `rig`, `calibration` and `cameras`
    (the nominal cameras, which name the rig's cameras) and say how IR sources are lit (`light`,
    `lit`, `source_positions_base`).
    """

    #: True when the arm, the remotes and the ball are simulated (so the truth is known).
    simulated = False
    settings: Settings
    clock: SimClock | SystemClock
    arm_model: ArmModel
    arm: Arm
    rig: RigStream
    calibration: StereoCalibration | None
    cameras: list[WiimoteCamera]
    _connected = False

    @property
    def arm_connected(self) -> bool:
        """False when the arm has no driver (a `robot.ParkedArm`: it stays put, refuses to move)."""
        return bool(getattr(self.arm, "connected", True))

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

    def poll(self) -> list[TrackedFrame]:
        """Read the remotes (and track, once calibrated)."""
        return self.rig.poll()

    def advance(self, seconds: float, step: float = 0.001) -> list[TrackedFrame]:
        """Let `seconds` pass in `step`s, reading the remotes after each: a simulated clock jumps,
        the system clock sleeps. Returns the tracked frames read meanwhile."""
        return self.wait_until(self.clock.now() + seconds, step)

    def wait_until(self, t: float, step: float = 0.001) -> list[TrackedFrame]:
        """Let time run to `t` (see `advance`)."""
        self.connect()
        frames: list[TrackedFrame] = []
        while self.clock.now() < t - 1e-12:
            self.clock.sleep(min(step, t - self.clock.now()))
            frames += self.poll()
        return frames

    def set_calibration(self, calibration: StereoCalibration) -> None:
        """Track with this calibration from now on."""
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

    def camera_names(self) -> Sequence[str]:
        return [c.name for c in self.cameras]


class SimWorld(RigWorld):
    """The simulated arm, rig and IR sources (see the module docstring)."""

    simulated = True

    def __init__(
        self,
        settings: Settings | None = None,
        *,
        seed: int = 0,
        realtime: bool = False,
        calibration: StereoCalibration | None = None,
        arm_model: ArmModel | None = None,
    ) -> None:
        self.settings = settings or Settings()
        self.realtime = realtime
        self.clock = SystemClock() if realtime else SimClock()
        self.rng = np.random.default_rng(seed)
        s = self.settings
        self.arm_model = arm_model or load_arm(s.arm, marker_offset=s.marker_offset_m, ball_offset=s.ball.offset_m)
        self.arm = SimulatedArm(
            self.arm_model,
            self.clock,
            rng=self._spawn(),
            tracking_error_rad=s.noise.joint_tracking_rad,
        )
        self.cameras = nominal_cameras(s.rig)
        self._lock = threading.Lock()
        self._fixed = {name: np.full(3, np.nan) for name in SOURCES}  # base-frame positions of fixed sources
        self._lit = dict.fromkeys(SOURCES, False)
        self.drivers, self.remotes = simulated_drivers(
            self.cameras,
            self.sources_at,
            self.clock,
            self._spawn(),
            sigma_px=s.noise.pixel_sigma_px,
            realtime=realtime,
            ir_format=s.rig.ir_format,
            sensitivity=s.rig.sensitivity,
        )
        self.rig = RigStream(self.drivers, calibration.Ps if calibration is not None else None)
        self.calibration = calibration
        self._connected = False

    def _spawn(self) -> np.random.Generator:
        return np.random.default_rng(self.rng.integers(2**63))

    def true_calibration_Ps(self) -> NDArray[np.float64]:
        """The simulated cameras' true projection matrices (C, 3, 4), in link1 (for reference)."""
        return np.stack([c.P for c in self.cameras])

    # -- IR sources -----------------------------------------------------------------------------

    def light(self, name: str, on: bool = True, position_base: ArrayLike | None = None) -> None:
        """Switch source `name` on or off; fixed sources (target, landing) take a base position."""
        if name not in SOURCES:
            raise ValueError(f"unknown IR source {name!r}; the world has {SOURCES}")
        with self._lock:
            if position_base is not None:
                self._fixed[name] = np.asarray(position_base, dtype=float).reshape(3)
            if on and name in ("target", "landing") and not np.isfinite(self._fixed[name]).all():
                raise ValueError(f"the {name} source needs a position before it can be lit")
            self._lit[name] = bool(on)

    def lit(self) -> dict[str, bool]:
        with self._lock:
            return dict(self._lit)

    def source_positions_base(self, q: ArrayLike | None = None) -> NDArray[np.float64]:
        """Positions (len(SOURCES), 3) in `base` of every source, NaN for unlit ones."""
        q = self.arm.state().q if q is None else np.asarray(q, dtype=float)
        with self._lock:
            lit, fixed = dict(self._lit), {k: v.copy() for k, v in self._fixed.items()}
        out = np.full((len(SOURCES), 3), np.nan)
        if lit["marker"] or lit["beacon_a"] or lit["beacon_b"]:
            T = self.arm_model.frame_placement(q, "marker")
            if lit["marker"]:
                out[0] = T[:3, 3]
            half = 0.5 * BEACON_DISTANCE_M * T[:3, 0]
            if lit["beacon_a"]:
                out[3] = T[:3, 3] - half
            if lit["beacon_b"]:
                out[4] = T[:3, 3] + half
        for i, name in ((1, "target"), (2, "landing")):
            if lit[name]:
                out[i] = fixed[name]
        return out

    def sources_at(self, t: float) -> NDArray[np.float64]:
        """The sources (len(SOURCES), 3) in `link1` at time t (what the remotes look at)."""
        q = self.arm.state().q
        return self.base_to_link1(self.source_positions_base(q), q)
