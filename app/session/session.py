"""The operator's session: the running system behind the command line and the dashboard.

A `Session` owns a world (`SimWorld`, or the real `HardwareWorld`), its calibration, the throw
library and the record of throws, and exposes what an operator does: calibrate with the robot,
track a target (joint-1 alignment), preview a throw, throw it, stop. Rules it enforces, whoever calls it:

* one operation at a time: a second call while one runs raises `Busy` (a clear message, never a
  second motion), whichever client or thread makes it;
* `stop()` is always allowed and never waits: it cancels the running operation and brakes the arm
  to rest within its limits;
* a throw executes only a preview made by the throw planner, hence validated, planned from the
  arm's pose at that moment, and used once: if the arm has moved since, preview again;
* a throw is executed only in simulation: on real hardware the ball's release and the landing's
  measurement have no driver yet, so `throw` refuses before anything moves (the preview stays).

Operations run in the caller's thread. With a simulated clock that is all there is; with the system
clock (the dashboard) `start()` runs a loop that keeps reading the rig while no operation runs,
and the dashboard runs operations in worker threads.
"""

from __future__ import annotations

import contextlib
import datetime as _dt
import threading
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from wiithrow.app.alignment.aligner import AlignmentResult, align_joint1
from wiithrow.app.calibration.robot import RobotCalibration, calibrate_with_robot
from wiithrow.app.errors import AppError
from wiithrow.app.settings import Settings
from wiithrow.app.studies.figures.mono import MonoVsStereo, mono_vs_stereo
from wiithrow.app.throws.execution import ThrowExecution, ball_of, execute_throw, planning_start, return_home
from wiithrow.app.throws.library_file import load_library
from wiithrow.app.worlds.simulated import RigWorld, SimWorld, nominal_cameras
from wiithrow.throwing import ThrowLibrary, ThrowPlanner, ValidatedThrow, flight_path
from wiithrow.vision import StereoCalibration

#: How far (m) outside the trained area a measured target may lie and still be thrown at: targets
#: on the floor sit on the area's edge, and the rig measures them with millimetres of noise.
DEFAULT_MARGIN_M = 0.01


class Busy(AppError):
    """Another operation is running; the request was refused without moving anything."""


@dataclass(frozen=True)
class ThrowPreview:
    """A validated throw ready to execute, and what the operator should see before saying yes."""

    id: int
    throw: ValidatedThrow
    target_xz: NDArray[np.float64]  # measured target in the throw plane (link1 x, z), m
    q1: float  # joint-1 angle, rad
    predicted_xz: NDArray[np.float64]
    predicted_base: NDArray[np.float64]
    arc_base: NDArray[np.float64] = field(repr=False)  # (N, 3) predicted ball path
    peak_speed: NDArray[np.float64] = field(repr=False)  # (nq,) rad/s
    velocity_limit: NDArray[np.float64] = field(repr=False)

    @property
    def duration_s(self) -> float:
        return float(self.throw.trajectory.duration)

    @property
    def speed_ratio(self) -> NDArray[np.float64]:
        """Peak joint speed over its limit, per joint (<= 1)."""
        return self.peak_speed / self.velocity_limit

    def to_dict(self, ball_offset_m: float) -> dict[str, Any]:
        """The plan as JSON (`wiithrow throw --dry-run --json`), checkable by anyone."""
        traj = self.throw.trajectory
        release = self.throw.release
        return {
            "joint1_rad": self.q1,
            "target_throw_plane_m": {"x": float(self.target_xz[0]), "z": float(self.target_xz[1])},
            "release_time_s": float(self.throw.release_time),
            "release_position_base_m": np.asarray(release.position).tolist(),
            "release_velocity_base_m_s": np.asarray(release.velocity).tolist(),
            "ball_offset_from_flange_m": [0.0, 0.0, ball_offset_m],
            "predicted_landing_base_m": self.predicted_base.tolist(),
            "predicted_landing_throw_plane_m": {"x": float(self.predicted_xz[0]), "z": float(self.predicted_xz[1])},
            "duration_s": self.duration_s,
            "peak_joint_speed_rad_s": self.peak_speed.tolist(),
            "joint_velocity_limit_rad_s": self.velocity_limit.tolist(),
            "trajectory": {
                "dt_s": float(traj.dt),
                "times_s": traj.times.tolist(),
                "positions_rad": traj.positions.tolist(),
            },
        }


@dataclass(frozen=True)
class ThrowRecord:
    """One executed throw, for the table of last throws (m, link1 throw plane unless named)."""

    index: int
    wall_time: str
    target_xz: NDArray[np.float64]  # as the rig measured the target
    landing_xz: NDArray[np.float64]  # as the rig measured the landing marker
    predicted_xz: NDArray[np.float64]
    q1: float
    execution: ThrowExecution = field(repr=False)
    target_base: NDArray[np.float64] | None = None  # the true target (simulation only)

    @property
    def error_m(self) -> float:
        """Distance between the measured landing and the measured target: what the operator sees."""
        return float(np.linalg.norm(self.landing_xz - self.target_xz))

    @property
    def true_error_m(self) -> float | None:
        """Simulation only: distance between the true landing and the true target at its height."""
        if self.target_base is None:
            return None
        return float(np.linalg.norm(self.execution.landing_base[:2] - self.target_base[:2]))


@dataclass(frozen=True)
class SessionSnapshot:
    """A consistent copy of what a view shows of the session (`Session.snapshot()`).

    `revision` grows by one with every event the session sends: a view that saw revision r has
    nothing new to draw while it stays r. `busy` is True while an operation holds the session.
    """

    revision: int
    busy: bool
    operation: str | None
    progress: tuple[str, float]
    message: str
    calibration: RobotCalibration | None
    alignment: AlignmentResult | None
    preview: ThrowPreview | None
    history: tuple[ThrowRecord, ...]

    @property
    def last_throw(self) -> ThrowRecord | None:
        return self.history[-1] if self.history else None


def study_mono_vs_stereo(
    settings: Settings, calibration: StereoCalibration, *, angles_deg: ArrayLike | None = None, seed: int = 0
) -> MonoVsStereo:
    """Fig. 6 (the mono method against the stereo rig) measured on a simulated twin of a world:
    the same `settings`, its own arm, rig and simulated clock, tracking with `calibration`. It never
    touches a running world, so it may run in another thread or process while operations run."""
    twin = SimWorld(settings, seed=seed, calibration=calibration)
    try:
        twin.connect()
        angles = None if angles_deg is None else np.asarray(angles_deg, dtype=float)
        return mono_vs_stereo(twin, calibration, angles_deg=angles, show_progress=False)
    finally:
        twin.close()


#: Why `Session.throw` refuses on real hardware.
NO_REAL_THROW = (
    "throwing on real hardware needs a driver for the ball's release (the gripper) and an IR "
    "marker placed where the ball lands, which this version does not have: Preview throw shows the plan"
)


class Session:
    """The running system for one operator (see the module docstring)."""

    def __init__(
        self,
        world: RigWorld,
        *,
        library: ThrowLibrary | None = None,
        rng: np.random.Generator | None = None,
        margin_m: float = DEFAULT_MARGIN_M,
    ) -> None:
        self.world = world
        self._library = library
        self._planner: ThrowPlanner | None = None
        self.margin_m = margin_m
        self.rng = rng if rng is not None else np.random.default_rng(0)
        self._op_lock = threading.Lock()
        self._cancel = threading.Event()
        self._state_lock = threading.Lock()
        self.operation: str | None = None
        self.progress: tuple[str, float] = ("", 0.0)
        self.calibration_result: RobotCalibration | None = None
        self.alignment: AlignmentResult | None = None
        self.preview: ThrowPreview | None = None
        self.history: list[ThrowRecord] = []
        self.last_message = ""
        self._next_preview = 1
        self._listeners: list[Callable[[str], None]] = []
        self._revision = 0
        self._loop: threading.Thread | None = None
        self._running = threading.Event()

    @property
    def library(self) -> ThrowLibrary:
        """The trained throws (the shipped library of the simulated PA-10 unless one was given)."""
        if self._library is None:
            self._library = load_library()
        return self._library

    def use_library(self, library: ThrowLibrary) -> None:
        """Throw with these trained throws from now on."""
        with self._operation("library"):
            self._library, self._planner = library, None
            self.preview = None

    @property
    def planner(self) -> ThrowPlanner:
        if self._planner is None:
            self._planner = ThrowPlanner(self.world.arm_model, self.library, margin=self.margin_m)
        return self._planner

    # -- plumbing ---------------------------------------------------------------------------------

    def subscribe(self, listener: Callable[[str], None]) -> None:
        """`listener(event)` is called after every change ("operation", "progress", "calibration",
        "alignment", "preview", "throw", "stop", "target", "home")."""
        self._listeners.append(listener)

    def unsubscribe(self, listener: Callable[[str], None]) -> None:
        if listener in self._listeners:
            self._listeners.remove(listener)

    def _notify(self, event: str) -> None:
        with self._state_lock:
            self._revision += 1
        for listener in list(self._listeners):
            try:
                listener(event)
            except Exception:  # a broken view must not break the session
                pass

    @contextlib.contextmanager
    def _operation(self, name: str) -> Iterator[None]:
        if not self._op_lock.acquire(blocking=False):
            raise Busy(f"{self.operation or 'another operation'} is running: wait for it to finish or press Stop")
        with self._state_lock:
            self.operation = name
            self.progress = (name, 0.0)
        self._cancel.clear()
        self._notify("operation")
        try:
            yield
        finally:
            with self._state_lock:
                self.operation = None
            self._op_lock.release()
            self._notify("operation")

    def _report(self, message: str, fraction: float) -> None:
        with self._state_lock:
            self.progress = (message, float(fraction))
        self._notify("progress")

    @property
    def busy(self) -> bool:
        return self._op_lock.locked()

    def snapshot(self) -> SessionSnapshot:
        """Everything a view shows of the session, read at once (see `SessionSnapshot`)."""
        with self._state_lock:
            return SessionSnapshot(
                self._revision,
                self._op_lock.locked(),
                self.operation,
                self.progress,
                self.last_message,
                self.calibration_result,
                self.alignment,
                self.preview,
                tuple(self.history),
            )

    # -- what the operator does -------------------------------------------------------------------

    def calibrate(
        self, n_poses: int = 30, *, out: str | None = None, show_progress: bool = False, design: str = "optimal"
    ) -> RobotCalibration:
        """The paper's procedure: the arm shows the rig its LED at `n_poses` poses; the rig is
        calibrated in link1 and used for tracking from now on."""
        with self._operation("calibration"):
            world = self.world
            lit = world.lit()
            for name, on in lit.items():
                if on and name != "marker":
                    world.light(name, False)
            world.light("marker", True)
            try:
                result = calibrate_with_robot(
                    world.arm,
                    world.arm_model,
                    world.rig,
                    world.clock,
                    nominal_cameras(world.settings.rig),
                    n_poses=n_poses,
                    design=design,
                    out=out,
                    rng=np.random.default_rng(self.rng.integers(2**63)),
                    progress=self._calibration_progress,
                    cancel=self._cancel,
                    show_progress=show_progress,
                    meta={"arm": world.arm_model.name},
                )
            finally:
                world.light("marker", False)
                for name, on in lit.items():
                    if on and name != "marker":
                        world.light(name, True)
            world.set_calibration(result.calibration)
            return_home(world, self._cancel)
            self.calibration_result = result
            self.alignment = None
            self.preview = None
        self._notify("calibration")
        return result

    def _calibration_progress(self, done: int, total: int, *rest: Any) -> None:
        self._report(f"calibration pose {done}/{total}", done / max(total, 1))

    def use_calibration(self, calibration: StereoCalibration) -> None:
        """Track with a calibration made earlier (e.g. loaded from a file)."""
        with self._operation("calibration"):
            self.world.set_calibration(calibration)
            self.alignment = None
            self.preview = None
        self._notify("calibration")

    def set_target(self, position_base: ArrayLike) -> None:
        """Place the simulated IR target (base frame, m). Allowed any time: targets may move."""
        self.world.light("target", True, position_base)
        with self._state_lock:
            self.preview = None
        self._notify("target")

    def align(self, **options: Any) -> AlignmentResult:
        """Turn joint 1 until the target lies in the throw plane (see wiithrow.app.alignment.aligner)."""
        with self._operation("tracking"):
            world = self.world
            if world.rig.tracker is None:
                raise AppError("track the target after calibrating the rig (Calibrate first)")
            result = align_joint1(
                world.arm,
                world.arm_model,
                world.rig,
                world.clock,
                cancel=self._cancel,
                progress=lambda phase, y: self._report(f"tracking: {phase}", 0.5),
                **options,
            )
            self.alignment = result
            self.preview = None
            self.last_message = result.message
        self._notify("alignment")
        return result

    def plan_preview(self, *, margin_m: float | None = None) -> ThrowPreview:
        """Plan and validate the throw at the aligned target, from the arm's current pose."""
        with self._operation("preview"):
            if self.alignment is None or not self.alignment.converged:
                raise AppError("track the target first: the throw is planned in the plane joint 1 aligned")
            world = self.world
            if world.arm.is_moving():
                raise AppError("the arm is moving: wait for it to stop before previewing")
            q = planning_start(world)
            throw = self.planner.plan(self.alignment.throw_xz, q1=q[0], margin=margin_m, q_start=q)
            ball = ball_of(world)
            release = throw.release
            _, arc = flight_path(release.position, release.velocity, throw.landing_height, ball)
            velocities = throw.trajectory.velocities
            preview = ThrowPreview(
                self._next_preview,
                throw,
                np.asarray(self.alignment.throw_xz, float),
                float(q[0]),
                np.asarray(throw.predicted.xz, float),
                np.asarray(throw.predicted.landing.position, float),
                arc,
                np.abs(velocities).max(axis=0),
                world.arm_model.velocity_limit.copy(),
            )
            self._next_preview += 1
            self.preview = preview
        self._notify("preview")
        return preview

    def throw(self, preview_id: int) -> ThrowRecord:
        """Execute the preview `preview_id` (once); measure where the ball landed."""
        with self._operation("throw"):
            preview = self.preview
            if preview is None or preview.id != preview_id:
                raise AppError(
                    "that preview is no longer current (the target, the arm or the plan changed): preview again"
                )
            if not self.world.simulated:
                raise AppError(NO_REAL_THROW)
            self.preview = None  # a preview is thrown at most once, whatever happens next
            world = self.world
            execution = execute_throw(world, preview.throw, self.rng, cancel=self._cancel)
            true_target = world.source_positions_base()[1] if world.lit()["target"] else None
            record = ThrowRecord(
                len(self.history) + 1,
                _dt.datetime.now().isoformat(timespec="seconds"),
                preview.target_xz,
                execution.measured_xz,
                preview.predicted_xz,
                preview.q1,
                execution,
                None if true_target is None else np.asarray(true_target, float),
            )
            self.history.append(record)
        self._notify("throw")
        return record

    def home(self) -> None:
        """Move the arm to its home pose (an operation: one at a time; Stop cancels it). Joint 1
        turns too, so the alignment and the preview no longer hold."""
        with self._operation("home"):
            return_home(self.world, self._cancel)
            self.alignment = None
            self.preview = None
        self._notify("home")

    def stop(self) -> None:
        """Cancel what runs and brake the arm to rest now (always allowed, never waits)."""
        self._cancel.set()
        self.world.arm.stop()
        with self._state_lock:
            self.preview = None
        self.last_message = "stopped by the operator"
        self._notify("stop")

    # -- the real-time loop ---------------------------------------------------------------------------

    def start(self, period_s: float = 0.01) -> None:
        """Keep reading the rig while no operation runs (a real-time world; the dashboard)."""
        if self._loop is not None:
            return
        self.world.connect()
        self._running.set()

        def loop() -> None:
            while self._running.is_set():
                if not self._op_lock.locked():
                    try:
                        self.world.poll()
                    except Exception as exc:  # keep the loop alive; say what happened
                        self.last_message = f"rig read failed: {exc}"
                self.world.clock.sleep(period_s)

        self._loop = threading.Thread(target=loop, name="wiithrow-rig", daemon=True)
        self._loop.start()

    def close(self) -> None:
        self._running.clear()
        if self._loop is not None:
            self._loop.join(timeout=2.0)
            self._loop = None
        self.world.close()
