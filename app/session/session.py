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
* a throw needs a hand (the world's `gripper`): without one `throw` refuses before anything moves
  (the preview stays). A simulated world measures the landing itself; on hardware (and over the
  MuJoCo devices served as hardware) the throw ends with the landing unmeasured, and the operator
  puts the IR marker where the ball first touched down and calls `measure_landing` (the
  dashboard's *Measure landing*).

Operations run in the caller's thread. With a simulated clock that is all there is; with the system
clock (the dashboard) `start()` runs a loop that keeps reading the rig while no operation runs,
and the dashboard runs operations in worker threads.
"""

from __future__ import annotations

import contextlib
import dataclasses
import datetime as _dt
import threading
from collections.abc import Callable, Iterator
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from wiithrow.app.alignment import AlignmentResult, align_joint1
from wiithrow.app.calibration.poses import Design
from wiithrow.app.calibration.robot import RobotCalibration, calibrate_in_world
from wiithrow.app.calibration.wand import Frame, WandRun, calibrate_with_wand
from wiithrow.app.calibration.wand_recording import RecordingProgress
from wiithrow.app.errors import AppError
from wiithrow.app.session.records import SessionSnapshot, ThrowPreview, ThrowRecord
from wiithrow.app.throws.execution import ball_of, execute_throw, measure_marker, planning_start, return_home
from wiithrow.app.throws.library_file import load_library
from wiithrow.app.worlds import RigWorld, SimWorld
from wiithrow.app.worlds.base import NO_GRIPPER
from wiithrow.throwing import AnalyticPlanner, ThrowLibrary, ThrowPlanner, flight_path
from wiithrow.vision import StereoCalibration

#: How far (m) outside the trained area a measured target may lie and still be thrown at: targets
#: on the floor sit on the area's edge, and the rig measures them with millimetres of noise.
DEFAULT_MARGIN_M = 0.01


class Busy(AppError):
    """Another operation is running; the request was refused without moving anything."""


#: What the operator is asked after a throw on hardware.
PLACE_MARKER = "put the IR marker where the ball first touched down, cover the target, then press Measure landing"


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
        if library is not None:
            library.require_arm(world.arm_model.name)
        self.world = world
        self._library = library
        self._planner: ThrowPlanner | AnalyticPlanner | None = None
        self._analytic = False
        self.margin_m = margin_m
        self.rng = rng if rng is not None else np.random.default_rng(0)
        self._op_lock = threading.Lock()
        self._cancel = threading.Event()
        self._state_lock = threading.Lock()
        self.operation: str | None = None
        self.progress: tuple[str, float] = ("", 0.0)
        self.calibration_result: RobotCalibration | None = None
        self.wand_result: WandRun | None = None
        self.wand_progress: RecordingProgress | None = None
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
            library = load_library()
            library.require_arm(self.world.arm_model.name)
            self._library = library
        return self._library

    def use_library(self, library: ThrowLibrary) -> None:
        """Throw with these trained throws from now on."""
        library.require_arm(self.world.arm_model.name)
        with self._operation("library"):
            self._library, self._planner = library, None
            self.preview = None

    def use_analytic(self, analytic: bool = True) -> None:
        """Plan without the learning from now on (`throwing.AnalyticPlanner`: the nominal model's
        exact solution), or with it again: the baseline of what the learning adds."""
        with self._operation("library"):
            self._analytic, self._planner = bool(analytic), None
            self.preview = None

    @property
    def planner(self) -> ThrowPlanner | AnalyticPlanner:
        if self._planner is None:
            kind = AnalyticPlanner if self._analytic else ThrowPlanner
            self._planner = kind(self.world.arm_model, self.library, margin=self.margin_m)
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
                self.wand_result,
                self.wand_progress,
            )

    # -- what the operator does -------------------------------------------------------------------

    def calibrate(
        self, n_poses: int = 30, *, out: str | None = None, show_progress: bool = False, design: Design = "optimal"
    ) -> RobotCalibration:
        """The paper's procedure: the arm shows the rig its LED at `n_poses` poses; the rig is
        calibrated in link1 and used for tracking from now on. AppError before anything moves when
        the rig cannot be calibrated here (its markers come from another host)."""
        refused = self.world.rig.calibration_refused()
        if refused:
            raise AppError(refused)
        with self._operation("calibration"):
            world = self.world
            lit = world.lit()
            for name, on in lit.items():
                if on and name != "marker":
                    world.light(name, False)
            world.light("marker", True)
            try:
                result = calibrate_in_world(
                    world,
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

    def calibrate_wand(
        self,
        seconds: float = 60.0,
        wand_length_m: float = 0.3,
        *,
        frame: Frame = "camera",
        out: str | None = None,
        show_progress: bool = False,
    ) -> WandRun:
        """A wand calibration (`wiithrow.app.calibration.wand`): someone waves the wand in front of
        the rig for `seconds` (in simulation, a simulated person); the result tracks from now on
        (in link1: `wiithrow.app.worlds.base.on_link1`) and replaces the robot calibration's figures."""
        refused = self.world.rig.calibration_refused()
        if refused:
            raise AppError(refused)
        with self._operation("wand calibration"):
            world = self.world
            rng = np.random.default_rng(self.rng.integers(2**63))
            with self._state_lock:
                self.wand_progress = None
            if isinstance(world, SimWorld):
                world.wave_wand(seconds, wand_length_m, rng)
            try:
                run = calibrate_with_wand(
                    world,
                    seconds=seconds,
                    wand_length_m=wand_length_m,
                    frame=frame,
                    out=out,
                    rng=rng,
                    progress=self._wand_progress,
                    cancel=self._cancel,
                    show_progress=show_progress,
                    before_frame=lambda _: world.hold(None) if isinstance(world, SimWorld) else None,
                )
            finally:
                if isinstance(world, SimWorld):
                    world.hold(None)
            world.set_calibration(run.calibration)
            if frame == "robot":
                return_home(world, self._cancel)
            with self._state_lock:
                self.wand_result = run
                self.calibration_result = None
            self.alignment = None
            self.preview = None
        self._notify("calibration")
        return run

    def _wand_progress(self, progress: RecordingProgress) -> None:
        with self._state_lock:
            self.wand_progress = progress
        self._report(f"wand recording {100 * progress.done:.0f} %", progress.done)

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
            if not world.rig.calibrated:
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
            if self.world.gripper is None:
                raise AppError(NO_GRIPPER)
            self.preview = None  # a preview is thrown at most once, whatever happens next
            world = self.world
            execution = execute_throw(world, preview.throw, self.rng, cancel=self._cancel)
            true_target = world.source_position_base("target")
            record = ThrowRecord(
                len(self.history) + 1,
                _dt.datetime.now().isoformat(timespec="seconds"),
                preview.target_xz,
                execution.measured_xz,
                preview.predicted_xz,
                preview.q1,
                execution,
                true_target if np.isfinite(true_target).all() else None,
            )
            self.history.append(record)
            if not np.isfinite(execution.measured_link1).all() and not np.isfinite(execution.landing_base).all():
                self.last_message = PLACE_MARKER
        self._notify("throw")
        return record

    def measure_landing(self) -> ThrowRecord:
        """Measure the IR marker the operator put where the last throw's ball came down, and make it
        that throw's landing (AppError before any throw, or when the rig sees no marker)."""
        with self._operation("measure landing"):
            if not self.history:
                raise AppError("throw first: the landing of the last throw is measured")
            if not self.world.rig.calibrated:
                raise AppError("the rig measures the marker: calibrate it first")
            measured = measure_marker(self.world, self._cancel)
            if not np.isfinite(measured).all():
                raise AppError("the rig does not see a marker: " + PLACE_MARKER)
            record = self.history[-1]
            execution = dataclasses.replace(record.execution, measured_link1=measured)
            record = dataclasses.replace(record, landing_xz=measured[[0, 2]], execution=execution)
            self.history[-1] = record
            self.last_message = f"landing of throw {record.index} measured: error {1e3 * record.error_m:.0f} mm"
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
                        self.world.rig.poll()
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
