"""The operator's session: the running system behind the command line and the dashboard.

A `Session` owns a world (`SimWorld`, or the real `HardwareWorld`), its calibration, the throw
library and the record of throws, and exposes what an operator does: calibrate with the robot,
track a target (joint-1 alignment), preview a throw, throw it, stop, and train the throw library
on its arm (`wiithrow.app.session.training`). Rules it enforces, whoever calls it:

* one operation at a time: a second call while one runs raises `Busy` (a clear message, never a
  second motion), whichever client or thread makes it;
* each operation's precondition is written once (`wiithrow.app.session.refusals`):
  `refusal(op)` says why `op` may not start now (or None), the operation raises that same text as
  it begins, and the dashboard shows it beside the disabled button and answers a click with it;
* `stop()` is always allowed and never waits: it cancels the running operation and brakes the arm
  to rest within its limits;
* a throw executes only a preview made by the throw planner, hence validated, planned from the
  arm's pose at that moment, and used once: if the arm has moved since, preview again; the
  planner aims it at the target's measured azimuth, turned by the library's learned sideways
  correction (`ThrowPlanner.aim`), so joint 1 may turn a little from the alignment's angle;
* a throw's error is its measured landing against its measured target in 3D, along / across /
  total (`ThrowRecord.error`, `wiithrow.throwing.landing_error`);
* a throw needs a hand (the world's `gripper`): without one `throw` refuses before anything moves
  (the preview stays). A simulated world measures the landing itself; on hardware (and over the
  MuJoCo devices served as hardware) the throw ends with the landing unmeasured, and the operator
  puts the IR marker where the ball first touched down and calls `measure_landing` (the
  dashboard's *Measure landing*);
* a throw that fails while it runs (whatever raised: the rig, the network, a driver, a Stop) ends
  with the arm at rest and the hand as its phase demands (`wiithrow.app.throws.safe_stop`), is
  kept in the history as failed with its one-line reason, which is also the session's message;
* the library keeps learning (`wiithrow.app.throws.learning`), unless `learn=False` or
  `set_learning(False)`: every throw whose landing was measured (a simulated world's own
  measurement, or `measure_landing`) and is credible joins it once, the planner serves the next
  target from the refitted regression unless the update made it worse, and with a library folder
  (`store`) each update is a new version; the throw's record says what the join did
  (`ThrowRecord.learned`). Which library is in use, its versions and the operator's choices about
  them: `wiithrow.app.session.library_use`.

State: one immutable `SessionSnapshot` (`snapshot()`), replaced under the session's lock by a
`dataclasses.replace`d copy at every change, each change followed by an `Event` to the listeners
(`subscribe`). Readers get the snapshot (the properties `operation`, `preview`, `alignment`,
`history`, ... read one field of it); nothing writes a field in place. Operations and events are
the enums of `wiithrow.app.session.operations`.

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
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from wiithrow.app.alignment import AlignmentOptions, AlignmentResult, align_joint1
from wiithrow.app.calibration.poses import Design
from wiithrow.app.calibration.robot import DEFAULT_POSES, RobotCalibration, RobotCalibrationOptions, calibrate_in_world
from wiithrow.app.calibration.wand import Frame, WandRun, calibrate_with_wand
from wiithrow.app.calibration.wand_capture import CaptureProgress
from wiithrow.app.errors import AppError, LandingNotMeasured
from wiithrow.app.network.source_pin import ChoosesSource
from wiithrow.app.session.library_use import LibraryOperations
from wiithrow.app.session.operations import Event, Operation
from wiithrow.app.session.records import SessionSnapshot, ThrowPreview, ThrowRecord, failed_throw_record, preview_of
from wiithrow.app.session.refusals import PREVIEW_FIRST, Busy, refusal
from wiithrow.app.session.rig_loop import RigLoop
from wiithrow.app.session.snapshot_fields import SnapshotFields
from wiithrow.app.session.status import (
    CALIBRATING_POSE,
    STOPPED_AFTER_RELEASE,
    calibration_state,
    measured_again_line,
)
from wiithrow.app.session.training import TrainingOperations
from wiithrow.app.throws.execution import execute_throw, measure_landing_marker, planning_start, return_home
from wiithrow.app.throws.learning import LearningLibrary, NotJoined
from wiithrow.app.throws.library_store import LibraryStore, VersionInfo
from wiithrow.app.throws.safe_stop import ThrowFailed, ThrowFault, ThrowInterrupted
from wiithrow.app.worlds import RigWorld
from wiithrow.throwing import AnalyticPlanner, ThrowingError, ThrowLibrary, ThrowPlanner
from wiithrow.throwing.reach import check_target_reach
from wiithrow.vision import StereoCalibration

__all__ = ["DEFAULT_MARGIN_M", "PLACE_MARKER", "Busy", "Session"]

#: How far (m) outside the trained area a measured target may lie and still be thrown at: targets
#: on the floor sit on the area's edge, and the rig measures them with millimetres of noise.
DEFAULT_MARGIN_M = 0.01

#: What the operator is asked after a throw on hardware.
PLACE_MARKER = "put the IR marker where the ball first touched down, cover the target, then press Measure landing"

#: Why a throw of a preview that was replaced, thrown or cleared is refused.
NOT_CURRENT = "that preview is no longer current (the target, the arm or the plan changed): preview again"

Listener = Callable[[Event], None]


#: Who pressed Stop, unless told otherwise (`Session.stop`).
OPERATOR = "the operator"
#: What Track target's progress says in each phase of the alignment (`Joint1Aligner.phase`).
ALIGNMENT_PHASES = {
    "acquire": "looking for the target",
    "search": "searching for the target (sweeping joint 1)",
    "track": "turning joint 1 to bring the target into the throw plane",
}


class Session(LibraryOperations, TrainingOperations, SnapshotFields):
    """The running system for one operator (see the module docstring)."""

    def __init__(
        self,
        world: RigWorld,
        *,
        library: ThrowLibrary | None = None,
        rng: np.random.Generator | None = None,
        margin_m: float = DEFAULT_MARGIN_M,
        learn: bool = True,
        store: LibraryStore | None = None,
        version: VersionInfo | None = None,
    ) -> None:
        """`library`: the library in use (None: the library folder's version in use, else the shipped
        one), `version` its version in `store`, the library folder whose versions the learning
        and the training write (None: no versions, the learning stays in memory); `learn`: measured
        throws join the library (module docstring)."""
        if library is not None:
            library.require_arm(world.arm_model.name)
        self.world = world
        # the planner's configuration: changed only inside an operation (Operation.CHANGE_PLANNER)
        self._library = library
        self._library_given = library is not None
        self._version = version
        self._store = store
        self._noted: set[tuple[int, str]] = set()  # (version, calibration) pairs whose mismatch was said
        self._learning: LearningLibrary | None = None
        self._thrown: dict[int, ThrowPreview] = {}  # the last throw's preview (its parameters), by record index
        self._planner: ThrowPlanner | AnalyticPlanner | None = None
        self._analytic = False
        self.margin_m = margin_m
        self.rng = rng if rng is not None else np.random.default_rng(0)
        self._cancel = threading.Event()
        self._stopped_by = OPERATOR  # who pressed Stop last (`stop`)
        self._state_lock = threading.Lock()
        self._state = SessionSnapshot(learning=bool(learn))
        self._listeners: list[Listener] = []
        self._loop: RigLoop | None = None
        self._training_library: Path | None = None  # where a training run writes (`training_library`)

    # -- the state: one snapshot, replaced under the lock -------------------------------------------

    def snapshot(self) -> SessionSnapshot:
        """The session's whole state now (immutable: `SessionSnapshot`)."""
        with self._state_lock:
            return self._state

    def _update(self, event: Event, **changes: Any) -> SessionSnapshot:
        """Replace the state by a copy with `changes` (fields of `SessionSnapshot`) and a new
        revision, then tell the listeners `event`."""
        with self._state_lock:
            self._state = state = dataclasses.replace(self._state, revision=self._state.revision + 1, **changes)
        self._notify(event)
        return state

    def refusal(self, op: Operation) -> str | None:
        """Why `op` may not start now (one line), or None when it may
        (`wiithrow.app.session.refusals`: the one place each precondition is written)."""
        with self._state_lock:
            refused = refusal(op, self._state, self.world)
        return refused.reason if refused is not None else None

    def refusals(self, ops: tuple[Operation, ...] = tuple(Operation)) -> dict[Operation, str | None]:
        """`refusal` of each of `ops`, all read from one state."""
        with self._state_lock:
            state = self._state
            found = {op: refusal(op, state, self.world) for op in ops}
        return {op: r.reason if r is not None else None for op, r in found.items()}

    # -- the planner ------------------------------------------------------------------------------

    def set_learning(self, on: bool) -> None:
        """Let measured throws join the library from now on (True), or keep it as it is (False).
        Refused while an operation runs, like every change of the planner."""
        with self._operation(Operation.CHANGE_PLANNER):
            self._update(
                Event.PLANNER,
                learning=bool(on),
                message="measured throws join the library" if on else "the library no longer learns",
            )

    def use_analytic(self, analytic: bool = True) -> None:
        """Plan without the learning from now on (`throwing.AnalyticPlanner`: the nominal model's
        exact solution), or with it again: the baseline of what the learning adds."""
        with self._operation(Operation.CHANGE_PLANNER):
            self._analytic, self._planner = bool(analytic), None
            self._update(Event.PLANNER, preview=None)

    # -- plumbing ---------------------------------------------------------------------------------

    def subscribe(self, listener: Listener) -> None:
        """`listener(event)` is called after every change (an `Event`), in the thread that made it."""
        self._listeners.append(listener)

    def unsubscribe(self, listener: Listener) -> None:
        if listener in self._listeners:
            self._listeners.remove(listener)

    def _notify(self, event: Event) -> None:
        for listener in list(self._listeners):
            try:
                listener(event)
            except Exception:  # a broken view must not break the session
                pass

    @contextlib.contextmanager
    def _operation(self, op: Operation, *, instead: dict[str, str] | None = None) -> Iterator[None]:
        """Run `op`: refused (its `refusal`, raised; `instead` may say a reason more precisely for
        this call's arguments) unless it may start; marked running in the same step under the
        lock, so that two callers never both start."""
        with self._state_lock:
            refused = refusal(op, self._state, self.world)
            if refused is not None:
                if instead and refused.reason in instead:
                    refused = dataclasses.replace(refused, reason=instead[refused.reason])
                raise refused.error()
            state = self._state
            self._state = dataclasses.replace(state, revision=state.revision + 1, operation=op, progress=("", 0.0))
        self._cancel.clear()
        self._notify(Event.OPERATION)
        try:
            yield
        finally:
            self._update(Event.OPERATION, operation=None)

    def _report(self, message: str, fraction: float) -> None:
        self._update(Event.PROGRESS, progress=(message, float(fraction)))

    # -- what the operator does -------------------------------------------------------------------

    def calibrate(
        self,
        n_poses: int = DEFAULT_POSES,
        *,
        out: str | None = None,
        show_progress: bool = False,
        design: Design = "optimal",
    ) -> RobotCalibration:
        """The paper's procedure: the arm shows the rig its LED at `n_poses` poses; the rig is
        calibrated in link1 and used for tracking from now on. Refused (AppError) before anything
        moves when `refusal(Operation.CALIBRATE)` says so (e.g. the markers come from another host)."""
        with self._operation(Operation.CALIBRATE):
            world = self.world
            lit = world.lit()
            for name, on in lit.items():
                if on and name != "marker":
                    world.light(name, False)
            world.light("marker", True)
            options = RobotCalibrationOptions(
                n_poses=n_poses,
                design=design,
                out=out,
                show_progress=show_progress,
                meta={"arm": world.arm_model.name},
            )
            try:
                result = calibrate_in_world(
                    world,
                    options,
                    rng=np.random.default_rng(self.rng.integers(2**63)),
                    progress=self._calibration_progress,
                    cancel=self._cancel,
                )
            finally:
                world.light("marker", False)
                for name, on in lit.items():
                    if on and name != "marker":
                        world.light(name, True)
            world.set_calibration(result.calibration)
            return_home(world, self._cancel)
            self._update(Event.CALIBRATION, calibration=result, alignment=None, preview=None)
        return result

    def _calibration_progress(self, done: int, total: int, message: str) -> None:
        self._report(CALIBRATING_POSE.format(done=done, total=total), done / max(total, 1))

    def calibration_state(self) -> str:
        """The rig's calibration in one phrase (`wiithrow.app.session.status.calibration_state`:
        "calibrating: pose k/N", "calibrated with the robot (N poses)", "not calibrated", ...)."""
        return calibration_state(self.snapshot(), self.world.calibration is not None)

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
        the rig for `seconds` (in a simulated world, its simulated person: the world's
        `wand_waver`); the result tracks from now on (in link1: `wiithrow.app.worlds.base.on_link1`)
        and replaces the robot calibration's figures."""
        with self._operation(Operation.CALIBRATE_WAND):
            world = self.world
            waver = world.wand_waver
            rng = np.random.default_rng(self.rng.integers(2**63))
            self._update(Event.PROGRESS, wand_progress=None)
            if waver is not None:
                waver.wave_wand(seconds, wand_length_m, rng)
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
                    before_frame=(lambda _: waver.put_away()) if waver is not None else None,
                )
            finally:
                if waver is not None:
                    waver.put_away()
            world.set_calibration(run.calibration)
            if frame == "robot":
                return_home(world, self._cancel)
            self._update(Event.CALIBRATION, wand=run, calibration=None, alignment=None, preview=None)
        return run

    def _wand_progress(self, progress: CaptureProgress) -> None:
        self._update(
            Event.PROGRESS,
            wand_progress=progress,
            progress=(f"wand capture {100 * progress.done:.0f} %", progress.done),
        )

    def use_calibration(self, calibration: StereoCalibration) -> None:
        """Track with a calibration made earlier (e.g. loaded from a file)."""
        with self._operation(Operation.LOAD_CALIBRATION):
            self.world.set_calibration(calibration)
            self._update(Event.CALIBRATION, alignment=None, preview=None)

    def set_target(self, position_base: ArrayLike) -> None:
        """Place the simulated IR target (base frame, m). Allowed whenever
        `refusal(Operation.MOVE_TARGET)` is None: idle, or while tracking (targets may move); AppError
        for a position no throw of the arm can reach (`throwing.reach`: not finite, or beyond it)."""
        with self._state_lock:
            refused = refusal(Operation.MOVE_TARGET, self._state, self.world)
        if refused is not None:
            raise refused.error()
        p = np.asarray(position_base, dtype=float).reshape(3)
        try:  # a position no throw of this arm reaches (a NaN, 1e300) is one line, never planned for
            check_target_reach(self.world.arm_model, p)
        except ThrowingError as exc:
            raise AppError(str(exc)) from None
        self.world.light("target", True, p)
        self._update(Event.TARGET, preview=None, target_base=p.copy())

    def align(self, options: AlignmentOptions | None = None) -> AlignmentResult:
        """Turn joint 1 until the target lies in the throw plane (see wiithrow.app.alignment.aligner)."""
        with self._operation(Operation.TRACK):
            placed = self.snapshot().target_base
            result = align_joint1(
                self.world,
                options,
                cancel=self._cancel,
                progress=lambda phase, y: self._report(ALIGNMENT_PHASES.get(phase, phase), 0.5),
            )
            self._update(
                Event.ALIGNMENT, alignment=result, preview=None, message=result.message, aligned_target_base=placed
            )
        return result

    def plan_preview(self, *, margin_m: float | None = None) -> ThrowPreview:
        """Plan and validate the throw at the aligned target, from the arm's current pose."""
        with self._operation(Operation.PREVIEW):
            state = self.snapshot()
            alignment = state.alignment
            assert alignment is not None  # refusal(PREVIEW) holds it
            world = self.world
            if world.arm.is_moving():
                raise AppError("the arm is moving: wait for it to stop before previewing")
            q = planning_start(world)
            target = np.asarray(alignment.position_base, float)  # measured, in base
            distance, azimuth = float(np.hypot(target[0], target[1])), float(np.arctan2(target[1], target[0]))
            aim = self.planner.aim(distance, float(target[2]), azimuth)  # a ThrowingError as the plan's
            throw = self.planner.plan(aim.xz, q1=aim.q1, margin=margin_m, q_start=q)
            preview = preview_of(
                world,
                state.previews_made + 1,
                throw,
                aim.xz,
                aim.q1,
                target_measured_base=target,
                across_m=aim.across_m,
            )
            self._update(Event.PREVIEW, preview=preview, previews_made=preview.id)
            self.tell_calibration_note()  # a library trained with another calibration: said once
        return preview

    def throw(self, preview_id: int) -> ThrowRecord:
        """Execute the preview `preview_id` (once); measure where the ball landed."""
        with self._operation(Operation.THROW, instead={PREVIEW_FIRST: NOT_CURRENT}):
            preview = self.snapshot().preview
            if preview is None or preview.id != preview_id:
                raise AppError(NOT_CURRENT)
            self._update(Event.PREVIEW, preview=None)  # a preview is thrown at most once, whatever happens next
            world = self.world
            try:
                execution = execute_throw(world, preview.throw, cancel=self._cancel)
            except (ThrowFailed, ThrowInterrupted) as failed:  # the arm rests, the hand as the phase demands
                self._record_failed_throw(preview, failed.fault)
                raise
            true_target = world.source_position_base("target")
            history = self.snapshot().history
            learned = self._join(preview, execution.measured_plane, "simulated measurement", execution.release_late_s)
            record = ThrowRecord(
                len(history) + 1,
                _dt.datetime.now().isoformat(timespec="seconds"),
                preview.target_xz,
                execution.measured_xz,
                preview.predicted_xz,
                preview.q1,
                execution,
                true_target if np.isfinite(true_target).all() else None,
                learned=learned,
                target_measured_base=preview.target_measured_base,
            )
            self._thrown = {record.index: preview}  # what Measure landing joins, if it was not measured
            if self._cancel.is_set():  # a Stop came after the release: the ball flew, the arm braked
                record = dataclasses.replace(record, failure=self._by_whom(STOPPED_AFTER_RELEASE))
            unmeasured = (
                not np.isfinite(execution.measured_link1).all() and not np.isfinite(execution.landing_base).all()
            )
            changes: dict[str, Any] = {"message": PLACE_MARKER} if unmeasured else {}
            if record.failure is not None:
                changes = {"message": record.failure}
            elif execution.late_release is not None:  # the ball flew, late: said, and kept out of the library
                changes = {"message": f"throw {record.index}: {execution.late_release}"}
            self._update(Event.THROW, history=(*history, record), **changes)
        return record

    def _record_failed_throw(self, preview: ThrowPreview, fault: ThrowFault) -> None:
        """A throw that ended early: in the history as failed, its reason the session's message."""
        try:  # the world may be what failed: the record is kept all the same
            true_target = self.world.source_position_base("target")
        except Exception:
            true_target = np.full(3, np.nan)
        history = self.snapshot().history  # the throw is the running operation: nothing else adds to it
        reason = self._by_whom(fault.reason)
        record = failed_throw_record(
            len(history) + 1,
            _dt.datetime.now().isoformat(timespec="seconds"),
            preview,
            reason,
            fault.released_at,
            true_target if np.isfinite(true_target).all() else None,
            ball_lost=fault.ball_lost,
            ball_lost_before_s=fault.ball_lost_before_s,
        )
        self._update(Event.THROW, history=(*history, record), message=reason)

    def measure_landing(self) -> ThrowRecord:
        """Measure the IR marker put where the last throw's ball came down, and make it that
        throw's landing (refused before any throw, or before the rig tracks). In a simulated world
        its operator puts the marker there first (the world's `landing_marker`); on hardware the
        operator has. AppError when the rig sees no marker."""
        with self._operation(Operation.MEASURE_LANDING):
            history = self.snapshot().history
            record = history[-1]
            marker = self.world.landing_marker
            if marker is not None:
                marker.place_landing_marker_at(record.execution.landing_base)
            measured, joint1 = measure_landing_marker(self.world, self._cancel)
            if not np.isfinite(measured).all():
                raise LandingNotMeasured("the rig does not see a marker: " + PLACE_MARKER)
            execution = dataclasses.replace(record.execution, measured_link1=measured, measured_q1=joint1)
            learned = record.learned
            if learned is None and record.failure is None:  # a throw joins once, with its first measurement
                learned = self._join_measured(record, execution.measured_plane)
            before = record.error
            record = dataclasses.replace(
                record, landing_xz=execution.measured_xz, execution=execution, learned=learned, measured_again=True
            )
            self._update(Event.THROW, history=(*history[:-1], record), message=measured_again_line(record, before))
        return record

    def _join(
        self,
        preview: ThrowPreview,
        measured_plane: np.ndarray,
        source: str,
        release_late_s: float | None,
        ball_lost: bool = False,
    ) -> dict[str, Any] | None:
        """The throw of `preview`, landed at `measured_plane` ((x, y, z) in its plane: y its across
        offset), joins the library if learning is on and its landing is credible (a late release, a
        ball lost in the wind-up, a landing far from the predicted one are refused:
        `LearningLibrary.join`)."""
        if not self.snapshot().learning or not np.isfinite(measured_plane).all():
            return None
        params = preview.throw.plan.params
        try:  # the throw happened: a join that fails loses nothing of its record
            summary = self.learning_library.join(
                params,
                preview.target_xz,
                np.asarray(measured_plane, float)[[0, 2]],
                source,
                release_late_s=release_late_s,
                ball_lost=ball_lost,
                predicted_xz=preview.predicted_xz,
                across_m=float(measured_plane[1]),
            )
        except (ThrowingError, NotJoined) as exc:
            return {"error": f"the throw did not join the library: {exc}"}
        return summary.to_dict() if summary is not None else None

    def _join_measured(self, record: ThrowRecord, measured_plane: np.ndarray) -> dict[str, Any] | None:
        preview = self._thrown.get(record.index)
        if preview is None:
            return None
        return self._join(preview, measured_plane, "measure landing", record.execution.release_late_s, record.ball_lost)

    def home(self) -> None:
        """Move the arm to its home pose (an operation: one at a time; Stop cancels it). Joint 1
        turns too, so the alignment and the preview no longer hold."""
        with self._operation(Operation.HOME):
            return_home(self.world, self._cancel)
            self._update(Event.HOME, alignment=None, preview=None)

    def follow_source(self, source: str, stream: str) -> str:
        """Follow the marker publisher (`source`, `stream`) the operator confirmed, from its next
        frame (`wiithrow.app.network.source_pin`): refused while an operation runs, or when the
        markers are this host's (`refusal(Operation.FOLLOW_SOURCE)`), or it does not ask to be
        followed now (AppError); what the operator is told."""
        with self._operation(Operation.FOLLOW_SOURCE):
            rig = self.world.rig
            assert isinstance(rig, ChoosesSource)  # (the refusal said so otherwise)
            return rig.adopt(source, stream)  # its notice goes to `tell` through the rig's notices

    def tell(self, message: str) -> None:
        """Show the operator `message` (one line: the status message), e.g. a marker source's notice."""
        self._update(Event.MESSAGE, message=message)

    def _clear_message(self, message: str) -> None:
        """Clear the status message if it is still `message` (a newer one stays)."""
        with self._state_lock:
            if self._state.message != message:
                return
            state = self._state
            self._state = dataclasses.replace(state, revision=state.revision + 1, message="")
        self._notify(Event.MESSAGE)

    def stop(self, by: str = OPERATOR) -> bool:
        """Cancel what runs and brake the arm to rest now (always allowed, never waits). `by`: who
        pressed Stop ("the operator", "a guest"), as the session's message and a stopped throw's
        failure say it. True if something ran (an operation, or the arm moving); else the message
        says that nothing was running."""
        self._stopped_by = by
        self._cancel.set()
        self.world.arm.stop()  # first: nothing is asked of the driver before the brake
        ran = self.busy or self._arm_moving()  # (an arm braking still moves; one at rest does not)
        message = f"stopped by {by}" if ran else f"Stop pressed by {by}: nothing was running, the arm is at rest"
        self._update(Event.STOP, preview=None, training_preview=None, message=message)
        return ran

    def _arm_moving(self) -> bool:
        try:
            return bool(self.world.arm.is_moving())
        except Exception:  # an arm that cannot say: Stop counts as stopping something
            return True

    def _by_whom(self, text: str) -> str:
        """`text` with "stopped by the operator" naming who pressed Stop last (`stop(by=...)`)."""
        return text.replace(f"stopped by {OPERATOR}", f"stopped by {self._stopped_by}")

    # -- the real-time loop ---------------------------------------------------------------------------

    def start(self, period_s: float = 0.01) -> None:
        """Keep reading the rig while no operation runs (a real-time world; the dashboard):
        `wiithrow.app.session.rig_loop.RigLoop`, its failed reads shown until one succeeds."""
        if self._loop is not None:
            return
        self.world.connect()
        self._loop = RigLoop(
            self.world,
            busy=lambda: self.busy,
            tell=self.tell,
            clear_message=self._clear_message,
            period_s=period_s,
        )
        self._loop.start()

    @contextlib.contextmanager
    def rig_loop_paused(self) -> Iterator[None]:
        """The real-time loop neither reads the rig nor lets time pass while the block runs: a long
        computation between operations (`wiithrow train`'s model-mismatch fit) in a world on a
        simulated clock, which the idle loop would otherwise run ahead of as fast as it can, its
        physics contending with the computation for the interpreter."""
        loop = self._loop
        if loop is None:
            yield
            return
        loop.stop()
        try:
            yield
        finally:
            loop.start()

    def close(self) -> None:
        if self._loop is not None:
            self._loop.stop()
            self._loop = None
        self.world.close()
