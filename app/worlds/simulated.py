"""The simulated world: the arm, the rig on link 1 and the IR sources, all on one clock.

`SimWorld` is a `wiithrow.app.worlds.base.RigWorld` whose arm is a `wiithrow.robot.SimulatedArm`
(1 kHz servo), whose remotes are simulated Wiimotes speaking the HID bytes behind the real driver
(`wiithrow.app.rig.simulated`), and whose IR sources it places and switches itself. The remotes ask
for the sources at the time of each report: their positions in `link1` follow from the arm's state
by forward kinematics (see the base module's frames).

A simulated person can also hold IR sources in front of the rig, after the world's own
(`wiithrow.app.worlds.held.HeldSources`, the world's `wand_waver`): a wand waved for a wand
calibration (`wave_wand`) or the three LEDs of an L-frame (`hold`); `hold(None)` puts them away.
The simulated operator marks a landing where asked (`place_landing_marker_at`, the world's
`landing_marker`: *Measure landing* in simulation).

With `noise.release_across_m` in its settings the ball leaves the hand that far beside the throw
plane (link1's +y), so every throw lands that far to one side: the developers' test of the
learned sideways correction.

A drift is injected mid-run with `drift(release_latency_s=..., ball_mass_kg=...)`: the hand lets go
that much later from then on, the ball flies with that mass (its drag), while the planner keeps
the library's ball: what a slower hand or another ball does to a trained library.

On a `SimClock` the world runs faster than real time: `pump(world.clock, world.rig, dt,
step_s=0.001)` moves the clock in 1 ms steps (the arm integrates at 1 kHz) and reads the remotes
at each step; with `realtime=True` it runs on
the system clock and a loop (the dashboard's) calls `poll`. The simulation knows the truth: the
cameras' true projection matrices (`true_calibration`) and where every source is.
"""

from __future__ import annotations

import dataclasses
import math
import threading

import numpy as np
from numpy.typing import ArrayLike, NDArray

from wiithrow.app.rig.simulated import simulated_drivers
from wiithrow.app.rig.source import MarkerSource
from wiithrow.app.rig.stream import RigStream
from wiithrow.app.rig.waiting import Cancel, pump
from wiithrow.app.settings import Settings
from wiithrow.app.worlds.base import BEACON_DISTANCE_M, SOURCES, BallFlight, MarkersOf, RigWorld, nominal_cameras
from wiithrow.app.worlds.grip import BallLost
from wiithrow.app.worlds.held import Held, HeldSources
from wiithrow.robot import ArmModel, JointState, SimulatedArm
from wiithrow.robot.gripper import SimulatedGripper
from wiithrow.throwing import ReleaseState, flight_path, fly, release_state
from wiithrow.vision import StereoCalibration
from wiithrow.vision.wand.waver import WandPath

#: Servo steps of arm positions a real-time world keeps (2 s at 1 kHz): how late a remote's report
#: may be made and still show the arm where it was at the report's time (`SimWorld.sources_at`).
REALTIME_HISTORY_STEPS = 2048


class SimWorld(RigWorld):
    """The simulated arm, rig and IR sources (see the module docstring)."""

    simulated = True
    title = "kinematic (simulated: the planner's own models)"

    def __init__(
        self,
        settings: Settings | None = None,
        *,
        seed: int = 0,
        realtime: bool = False,
        calibration: StereoCalibration | None = None,
        arm_model: ArmModel | None = None,
        markers: MarkersOf | None = None,
    ) -> None:
        """`markers(world)`: the marker source the world reads instead of its own remotes' rig
        (made from it once the world is built, e.g. `wiithrow.app.worlds.remote.simulated_loopback`)."""
        # the arm its settings name (a shipped one, or one they define: `Settings.load_arm`)
        s = self._init_simulated(settings, realtime, arm_model or (settings or Settings()).load_arm())
        self.rng = np.random.default_rng(seed)
        self.arm = SimulatedArm(
            self.arm_model,
            self.clock,
            rng=self._spawn(),
            tracking_error_rad=s.noise.joint_tracking_rad,
            history_steps=REALTIME_HISTORY_STEPS if realtime else 0,  # `sources_at`
        )
        self.cameras = nominal_cameras(s.rig)
        self._lock = threading.Lock()
        self._fixed = {name: np.full(3, np.nan) for name in SOURCES}  # base-frame positions of fixed sources
        self._lit = dict.fromkeys(SOURCES, False)
        self.held = HeldSources(self.cameras, self.clock)
        self.wand_waver = self.held
        self.landing_marker = self
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
        self.rig: MarkerSource = RigStream(self.drivers)
        self.calibration = None
        if calibration is not None:
            self.set_calibration(calibration)
        if markers is not None:
            self.rig = markers(self)
        self._connected = False
        # the hand opens on time, give or take the release jitter (no latency: the kinematic world
        # releases the ball where the plan does, up to its noise)
        self.gripper: SimulatedGripper = SimulatedGripper(
            self.clock, jitter_s=s.noise.release_jitter_s, rng=self._spawn()
        )
        self._release: ReleaseState | None = None
        self._lost_before_s: float | None = None  # the ball slipped out this long before the open (s)

    @property
    def release_latency_s(self) -> float:
        """The hand's latency now (s; 0 until a `drift`)."""
        return self.gripper.latency_s

    def drift(self, *, release_latency_s: float | None = None, ball_mass_kg: float | None = None) -> None:
        """Change the world mid-run (module docstring): the hand's latency (s, on top of its
        jitter) and the true ball's mass (kg; the settings' `ball`, checked by their bounds)."""
        if release_latency_s is not None:
            if not (math.isfinite(release_latency_s) and 0 <= release_latency_s <= 1.0):
                raise ValueError(f"release latency must be 0-1 s, got {release_latency_s}")
            self.gripper.latency_s = float(release_latency_s)
        if ball_mass_kg is not None:
            if not (math.isfinite(ball_mass_kg) and 0.001 <= ball_mass_kg <= 10.0):  # the settings' bounds
                raise ValueError(f"ball mass must be 0.001-10 kg, got {ball_mass_kg}")
            ball = dataclasses.replace(self.settings.ball, mass_kg=float(ball_mass_kg))
            self.settings = self.settings.replace(ball=ball)

    def _spawn(self) -> np.random.Generator:
        return np.random.default_rng(self.rng.integers(2**63))

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

    # -- the ball: released where the arm's `ball` frame is, flying with the planner's ballistics ----

    def load_ball(self, cancel: Cancel = None) -> None:
        """The operator puts the ball between the jaws, then the hand closes on it."""
        self.gripper.load_ball()
        super().load_ball(cancel)

    def after_open(self, cancel: Cancel = None) -> None:
        """Take the ball's release state at the instant the jaws open: the `ball` frame's position
        and velocity at the arm's actual state, interpolated between its 1 ms steps around that
        instant. On a simulated clock the world runs to that instant, reading the rig as it goes;
        in real time the arm's recorded steps say it (`SimulatedArm.state_at`, waiting on the
        clock only, never on the rig): however late this runs (a read that stalled across the
        release), the ball leaves from where the arm was when the jaws opened."""
        t = self.gripper.opened_at
        self._release = None
        lost = self.gripper.lost_at
        self._lost_before_s = None if lost is None else self.clock.now() - lost
        if t is None:
            return
        if self.realtime:
            self._release = self._recorded_release(t)
            return
        while self.clock.now() < t - 0.001:
            pump(self.clock, self.rig, min(0.01, t - 0.001 - self.clock.now()), step_s=0.001)
        step = math.floor(t * 1000.0 + 1e-9) / 1000.0
        if self.clock.now() < step:
            pump(self.clock, self.rig, step - self.clock.now(), step_s=0.001)
        before = self.arm.state()
        pump(self.clock, self.rig, 0.001, step_s=0.001)
        self._release = self._interpolated_release(before, self.arm.state(), t)

    def _recorded_release(self, t: float) -> ReleaseState:
        """The release state at `t` from the arm's recorded steps around it (real time): the clock
        is let pass (nothing read) until the step after `t` is taken. Beyond the recorded steps
        (`REALTIME_HISTORY_STEPS`, 2 s late) the arm's state now stands in."""
        arm = self.arm
        before = after = None
        if isinstance(arm, SimulatedArm):  # (the kinematic world's arm is)
            while self.clock.now() < t + arm.dt:
                self.clock.sleep(arm.dt)
            before, after = arm.state_at(t), arm.state_at(t + arm.dt)
        if before is None or after is None:
            before = after = arm.state()
        return self._interpolated_release(before, after, t)

    def _interpolated_release(self, before: JointState, after: JointState, t: float) -> ReleaseState:
        """The `ball` frame's release state at `t` between the arm's states `before` and `after`,
        the ball `noise.release_across_m` beside it along link1's +y (a ball held off-centre)."""
        alpha = 0.0 if after.t == before.t else (t - before.t) / (after.t - before.t)
        q = before.q + alpha * (after.q - before.q)
        dq = before.dq + alpha * (after.dq - before.dq)
        release = release_state(self.arm_model, q, dq, t)
        across = self.settings.noise.release_across_m
        if across == 0.0:
            return release
        y_link1 = self.arm_model.frame_placement(q, "link1")[:3, 1]  # link1's +y in base
        return dataclasses.replace(release, position=release.position + across * y_link1)

    def await_landing(self, surface_height: float, timeout_s: float = 5.0) -> BallFlight | None:
        """The flight (gravity and quadratic drag, `throwing.ballistics`) from the release down
        through `surface_height`: the ball's centre there is the landing. A ball that slipped out
        of the hand before it opened (`SimulatedGripper.slip_at`) flies no throw: BallLost."""
        release = self._release
        if release is None:
            if self._lost_before_s is not None:  # it slipped out before the open: no ball flies
                raise BallLost(self._lost_before_s)
            return None
        ball = self.ball()
        landing = fly(release.position, release.velocity, surface_height, ball)
        times, path = flight_path(release.position, release.velocity, surface_height, ball)
        return BallFlight(release, np.asarray(landing.position, float), release.time + times, path)

    def place_landing_marker(self, flight: BallFlight | None) -> bool:
        """The marker exactly where the ball came down."""
        if flight is None:
            return False
        return self.place_landing_marker_at(flight.landing_base)

    def place_landing_marker_at(self, landing_base: NDArray[np.float64]) -> bool:
        """The simulated operator puts the marker at `landing_base` (exactly)."""
        if not np.isfinite(landing_base).all():
            return False
        self.light("landing", True, landing_base)
        return True

    def remove_landing_marker(self) -> None:
        self.light("landing", False)

    def sources_at(self, t: float) -> NDArray[np.float64]:
        """The sources (len(SOURCES) + held, 3) in `link1` at time t (what the remotes look at).
        In real time the arm where it was at t (`SimulatedArm.position_at`: a report made late, by a
        host that was not scheduled for a while, shows the scene at its own time, as a real camera's
        frame does; a load of 8 lost the aligned target otherwise); on a simulated clock, where the
        remotes read at their reports' steps, the arm now."""
        arm = self.arm
        q = arm.position_at(t) if isinstance(arm, SimulatedArm) else arm.state().q
        own = self.base_to_link1(self.source_positions_base(q), q)
        return np.vstack([own, self.held(t)]) if self.held.holding else own

    # -- what a simulated person holds in front of the rig (`HeldSources`) -----------------------

    def hold(self, sources: Held | NDArray[np.float64] | None) -> None:
        """Hold IR sources in front of the rig (`HeldSources.hold`); None puts them away."""
        self.held.hold(sources)

    def wave_wand(self, seconds: float, wand_length_m: float, rng: np.random.Generator) -> WandPath:
        """A person waves a wand in front of the rig for `seconds` from now (`HeldSources.wave_wand`)."""
        return self.held.wave_wand(seconds, wand_length_m, rng)
