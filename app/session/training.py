"""The session's training operations: the paper's training procedure on the arm the session has,
one step per operation, for the dashboard's Training panel and `wiithrow train` (and any caller of
the session).

Owns `TrainingOperations`, the part of `Session` that runs a `TrainingRun`
(`wiithrow.app.throws.training_run`): start it over an area of the throw plane (bounded by the
arm's reach at the velocity margin, and refused unless the calibrated rig sees it with its margin:
`wiithrow.app.throws.area_view`) with a number of throws; for each target preview the throw
(the simulated operator's solution on the model, `throwing.operator.solve_throw`, planned from the
arm's pose and passed by the independent validator, `throwing.require_valid`: the same plan ->
validate -> preview -> confirm -> execute path as the Throw button), throw it on the operator's
confirmation (`wiithrow.app.throws.execution.execute_throw`, its safe stop included), measure the
landing marker the operator put down (in a simulated world its simulated operator puts it where
the ball came down: the label is that landing in the throw's plane, link1 at the joint-1 angle it
was thrown at, its (x, z) and how far beside the plane it came down), or retry or skip it; finish: the library of the measured throws is fitted,
checked (the regression's held-out error, leave-one-out as `wiithrow train` prints it, and the
area it covers), written as a new version of the library folder, and compared with the library in
use (`wiithrow.app.throws.library_compare`): it is put in use only by a choice (`finish_training`'s
`use`: "ask" leaves the choice to the operator, `choose_trained_library`; "if_better" uses it only
when it is better; "always"), never silently.

The run is saved after every step to its progress file (`training_file.progress_path`), so that a
Stop, a crash or a restart resumes where it was (`resume_training`): `trained.training.json` in the
library folder, or beside the library file the session was told to write (`train_to`, `--train-to`:
Finish writes that file too). The progress file names no path, so nothing it says is written anywhere. A
measured landing records what measured it (`training_run.Measurement`: the rig, its calibration's
fingerprint and frame, the time) and is checked for plausibility (`landing_checks`) when measured
and again before Finish fits the run: one that is not (an edited file) fails its throw, to retry or
skip, and nothing is fitted. A landing the rig does not see, or refuses as it is measured, leaves
the run as it was (`LandingNotMeasured`: measure again, or retry or skip), or fails its throw at once
with `fail_unmeasured` (how `wiithrow train` measures). A Stop during a training throw ends it
safely and leaves the run at that throw, marked failed: retry or skip it; so does a late release
(`ThrowExecution.release_late_s`: its landing is not the planned throw's, and never labels the
library). Each step's precondition is written once, in `wiithrow.app.session.refusals`; each step
is an `Operation` (one at a time, Stop always).
"""

from __future__ import annotations

import contextlib
import os
import threading
from collections.abc import Iterator
from pathlib import Path
from typing import TYPE_CHECKING, Any, NoReturn

import numpy as np

from wiithrow.app.errors import NO_MARKER_SEEN, AppError, LandingNotMeasured
from wiithrow.app.session.operations import Event, Operation
from wiithrow.app.session.records import SessionSnapshot, ThrowPreview, preview_of
from wiithrow.app.session.refusals import Busy
from wiithrow.app.session.status import ERROR_UNIT
from wiithrow.app.throws.area_view import require_area_in_view
from wiithrow.app.throws.execution import execute_throw, measure_landing_marker, planning_start, return_home
from wiithrow.app.throws.landing_checks import first_implausible, implausible_landing
from wiithrow.app.throws.library_compare import LibraryChoice, compare_libraries
from wiithrow.app.throws.library_file import save_library
from wiithrow.app.throws.library_store import Heldout, LibraryStore, VersionInfo
from wiithrow.app.throws.safe_stop import ThrowFailed, ThrowInterrupted
from wiithrow.app.throws.training_file import load_run, progress_path, save_run
from wiithrow.app.throws.training_run import (
    DEFAULT_THROWS,
    Measurement,
    TrainingOutcome,
    TrainingRun,
    library_of,
    reachable_area,
)
from wiithrow.app.worlds import RigWorld
from wiithrow.throwing import (
    Area,
    ThrowLibrary,
    ThrowPlanner,
    UnreachableTargetError,
    plan_throw,
    regression_leave_one_out_error,
    require_valid,
    shape_for,
)
from wiithrow.throwing.landing_error import landing_error
from wiithrow.throwing.operator import solve_throw
from wiithrow.throwing.reach import check_throw_plane_reach
from wiithrow.throwing.throw_plane import turned
from wiithrow.vision.stereo_calibration import calibration_fingerprint

#: Why a training throw of a preview that is no longer current is refused.
NOT_CURRENT_TRAINING = "that training preview is no longer current: preview the training throw again"
#: Why a session with neither a library folder nor a library file named trains nowhere.
NOWHERE_TO_TRAIN = (
    "no library folder to train into: the command gives one (--library-folder, or the settings' library_folder)"
)
#: The library file, in a library folder, whose progress file (`trained.training.json`) a run keeps.
FOLDER_RUN = "trained.json"
#: What Finish may do with the new library: leave the choice to the operator, use it only when it
#: is better than the one in use, or use it.
USES = ("ask", "if_better", "always")


class TrainingOperations:
    """The training steps of `Session` (module docstring). `Session` provides the state and the
    operation frame these methods use."""

    world: RigWorld
    _cancel: threading.Event
    _training_library: Path | None
    _store: LibraryStore | None

    # -- provided by Session ------------------------------------------------------------------------

    def snapshot(self) -> SessionSnapshot:
        raise NotImplementedError

    def _operation(
        self, op: Operation, *, instead: dict[str, str] | None = None
    ) -> contextlib.AbstractContextManager[None]:
        raise NotImplementedError

    def _update(self, event: Event, **changes: Any) -> SessionSnapshot:
        raise NotImplementedError

    if TYPE_CHECKING:  # provided by `LibraryOperations` (a stub here would hide it in Session's bases)

        def current_library(self) -> ThrowLibrary: ...

        def comparable_library(self) -> tuple[ThrowLibrary | None, VersionInfo | None]: ...

        @property
        def library_version(self) -> VersionInfo | None: ...

        def calibration_fingerprint(self) -> str | None: ...

        def _settle_choice(self, use: bool, by: str) -> str: ...

    # -- where the run is kept -----------------------------------------------------------------------

    @property
    def training_library(self) -> Path:
        """The library file whose progress file a run keeps (`progress_path`): the one `train_to`
        named, else `FOLDER_RUN` in the library folder (AppError with neither: `NOWHERE_TO_TRAIN`)."""
        if self._training_library is not None:
            return self._training_library
        if self._store is None:
            raise AppError(NOWHERE_TO_TRAIN)
        return self._store.folder / FOLDER_RUN

    def train_to(self, library: str | os.PathLike[str]) -> TrainingRun | None:
        """Write the next run's library to `library`, and resume the run saved beside it, if any
        (`resume_training`). A progress file that cannot be resumed is refused and nothing changes."""
        if self.snapshot().busy:
            raise Busy("busy: the training file is changed between operations")
        path = Path(library)
        run = self._saved_run(path)
        self._training_library = path
        return self._resumed(run)

    def resume_training(self) -> TrainingRun | None:
        """Take up the run saved beside `training_library` (None when there is none, or nowhere to
        train; a run of another arm, or a broken file, is refused with its name and left as it is)."""
        if self._training_library is None and self._store is None:
            return None
        return self._resumed(self._saved_run(self.training_library))

    def _saved_run(self, library: Path) -> TrainingRun | None:
        path = progress_path(library)
        run = load_run(path, library)
        arm = self.world.arm_model.name
        if run is not None and run.arm != arm:
            raise AppError(f"{path}: a training run of arm {run.arm!r}, and this arm is {arm!r}: move it away to train")
        return run

    def _resumed(self, run: TrainingRun | None) -> TrainingRun | None:
        if run is not None:
            self._update(
                Event.TRAINING,
                training=run,
                training_preview=None,
                message=f"training resumed from {progress_path(self.training_library)}: {run.progress_line()}",
            )
        return run

    def _save(self, run: TrainingRun) -> None:
        save_run(progress_path(self.training_library), run)

    def _step(self, run: TrainingRun, message: str, **changes: Any) -> TrainingRun:
        """Save `run`, then make it the session's (the file first: what the page shows is on disk)."""
        self._save(run)
        self._update(Event.TRAINING, training=run, message=message, **changes)
        return run

    @contextlib.contextmanager
    def _training(self, op: Operation, instead: dict[str, str] | None = None) -> Iterator[TrainingRun]:
        with self._operation(op, instead=instead):
            run = self.snapshot().training
            assert run is not None  # refusal(op) holds it
            yield run

    # -- the steps -----------------------------------------------------------------------------------

    def start_training(self, area: Area, count: int = DEFAULT_THROWS) -> TrainingRun:
        """A new run of `count` throws over `area` (link1 x, z ranges, m), the area bounded by the
        arm's reach at the velocity margin first (what was changed is the message); refused (one
        line naming the corner) when the calibrated rig does not see the bounded area with its
        margin (`wiithrow.app.throws.area_view`)."""
        with self._operation(Operation.TRAIN_START):
            world = self.world
            try:  # a corner no throw reaches (a NaN, 1e300) is one line before any solve
                for x in area.x:
                    for z in area.z:
                        check_throw_plane_reach(
                            world.arm_model, float(x), float(z), f"the area's corner x {x:g} z {z:g} m"
                        )
            except UnreachableTargetError as exc:
                raise AppError(str(exc)) from None
            bounded, notes = reachable_area(world.arm_model, area, world.ball())
            # every label is the rig's measurement: the rig must see where the run's balls come down
            require_area_in_view(bounded, world.rig.Ps, world.rig.camera_names)
            run = TrainingRun.start(world.arm_model.name, bounded, int(count))
            run = TrainingRun(run.arm, run.area, run.throws, tuple(notes))
            said = f" ({'; '.join(notes)})" if notes else ""
            return self._step(
                run,
                f"training started: {run.count} throws over {bounded}{said}; preview throw 1",
                training_preview=None,
                training_outcome=None,
            )

    def preview_training_throw(self) -> ThrowPreview:
        """Plan the current target's throw from the model (the simulated operator's solution), from
        the arm's pose, and validate it: the preview the operator confirms with `training_throw`."""
        with self._training(Operation.TRAIN_PREVIEW) as run:
            world = self.world
            arm = world.arm_model
            if world.arm.is_moving():
                raise AppError("the arm is moving: wait for it to stop before previewing")
            i, current = run.index, run.current
            assert i is not None and current is not None  # refusal(TRAIN_PREVIEW) holds it
            target = current.target
            try:
                params = solve_throw(arm, target, shape=shape_for(arm), ball=world.ball())
            except UnreachableTargetError as exc:
                raise AppError(f"training throw {i + 1}: {exc}; skip it") from None
            q = planning_start(world)
            plan = plan_throw(
                arm, params, float(target[1]), q1=float(q[0]), ball=world.ball(), q_start=q, target=target
            )
            throw = require_valid(plan, arm)  # the independent check: TrajectoryRejected says why not
            state = self.snapshot()
            preview = preview_of(world, state.previews_made + 1, throw, target, q[0])
            self._update(
                Event.TRAINING,
                training_preview=preview,
                previews_made=preview.id,
                message=f"training throw {i + 1}/{run.count} previewed: target x {target[0]:.3f} z {target[1]:.3f} m",
            )
        return preview

    def training_throw(self, preview_id: int) -> TrainingRun:
        """Throw the training preview `preview_id` (once): the arm throws, the hand lets go; the
        landing is measured next (`measure_training_landing`). After the throw the arm goes home,
        where the next training throw starts. A Stop or a fault ends the throw safely and marks it
        failed (retry or skip it), and is raised."""
        with self._training(Operation.TRAIN_THROW, {self._preview_first(): NOT_CURRENT_TRAINING}) as run:
            preview = self.snapshot().training_preview
            if preview is None or preview.id != preview_id:
                raise AppError(NOT_CURRENT_TRAINING)
            self._update(Event.TRAINING, training_preview=None)  # thrown at most once, whatever happens next
            i = run.index
            assert i is not None
            world = self.world
            try:
                execution = execute_throw(
                    world, preview.throw, measure=False, cancel=self._cancel, surface_height=float(preview.target_xz[1])
                )
            except (ThrowFailed, ThrowInterrupted) as failed:  # the arm rests, the hand as the phase demands
                self._step(
                    run.failed(failed.fault.reason), f"training throw {i + 1}: {failed.fault.reason}; retry or skip it"
                )
                raise
            if execution.late_release is not None:  # the ball flew, late: its landing labels nothing
                run = self._step(
                    run.failed(execution.late_release), f"training throw {i + 1}: {execution.late_release}; retry it"
                )
                return_home(world, self._cancel)
                return run
            run = run.thrown(
                preview.throw.plan.params, execution.landing_base, execution.release_tracking_m, preview.throw.q1
            )
            warning = run.throws[i].release_warning
            run = self._step(
                run,
                f"training throw {i + 1} thrown: put the IR marker where the ball first touched down, cover the target, "
                "then press Measure training landing" + (f" (⚠ {warning})" if warning else ""),
            )
            return_home(world, self._cancel)
        return run

    def _preview_first(self) -> str:
        run = self.snapshot().training
        i = run.index if run is not None else None
        return f"preview training throw {(i or 0) + 1} first"

    def measure_training_landing(self, *, fail_unmeasured: bool = False) -> TrainingRun:
        """Measure the landing marker of the current training throw: its label. In a simulated
        world its simulated operator puts the marker where the ball came down first; on hardware
        the operator has. `LandingNotMeasured` when the rig sees no marker, or one that cannot be
        the throw's (`landing_checks`): the run stays as it was (measure again, or retry or skip the
        throw), unless `fail_unmeasured`: then the throw is marked failed with why (saved), to retry
        or skip (a command's last look, or a simulated operator's marker that is not seen)."""
        with self._training(Operation.TRAIN_MEASURE) as run:
            i, current = run.index, run.current
            assert i is not None and current is not None
            marker = self.world.landing_marker
            if marker is not None and current.landing_base is not None:
                marker.place_landing_marker_at(current.landing_base)
            measured, joint1 = measure_landing_marker(self.world, self._cancel)
            Ps = self.world.rig.Ps  # what measured it: the rig's calibration now (a far host's, on a remote rig)
            if not np.isfinite(measured).all() or Ps is None:
                self._unmeasured(
                    run,
                    fail_unmeasured,
                    NO_MARKER_SEEN,
                    f"the rig does not see a marker: put the IR marker where the ball of training throw {i + 1} first "
                    "touched down, cover the target, then press Measure landing",
                )
            q1 = current.q1 if current.q1 is not None else joint1  # the throw's plane (a file from before: the rig's)
            plane = turned(measured, joint1 - q1)  # the landing in the throw's plane: x, across, z
            landed = plane[[0, 2]]
            by = Measurement.by_rig(calibration_fingerprint(Ps, "link1"), "link1")
            measured_run = run.landed(landed, by, float(plane[1]))
            why = implausible_landing(measured_run.throws[i], run.area, self.world.arm_model, self.world.ball())
            if why is not None:  # the run stays as it was: measure again, or retry or skip the throw
                self._unmeasured(
                    run,
                    fail_unmeasured,
                    f"its landing was refused: {why}",
                    f"training throw {i + 1}: {why}: is the marker where its ball first touched down? Measure again, "
                    "or retry or skip the throw",
                )
            miss = landing_error(turned(plane, q1), turned(np.array([current.target[0], 0.0, current.target[1]]), q1))
            run = self._step(
                measured_run,
                f"training throw {i + 1} measured: landed x {landed[0]:.3f} z {landed[1]:.3f} m, "
                f"{miss.words(ERROR_UNIT)} from its target"
                + (f" (⚠ {current.release_warning})" if current.release_warning else ""),
            )
        return run

    def _unmeasured(self, run: TrainingRun, fail: bool, reason: str, message: str) -> NoReturn:
        """The current throw's landing was not measured: with `fail` the throw is marked failed
        (`reason`, saved); `LandingNotMeasured` (`message`, the dashboard's words; `reason`) either way."""
        if fail:
            n = (run.index or 0) + 1
            self._step(run.failed(reason), f"training throw {n}: {reason}; retry or skip it")
        raise LandingNotMeasured(message, reason)

    def retry_training_throw(self) -> TrainingRun:
        """Set the current training throw up again (what it did is forgotten): preview it again."""
        with self._training(Operation.TRAIN_RETRY) as run:
            n = (run.index or 0) + 1
            return self._step(run.retried(), f"training throw {n} again: preview it", training_preview=None)

    def skip_training_throw(self) -> TrainingRun:
        """Leave the current training throw out of the library and go on to the next."""
        with self._training(Operation.TRAIN_SKIP) as run:
            n = (run.index or 0) + 1
            run = run.skip()
            return self._step(run, f"training throw {n} skipped: {run.progress_line()}", training_preview=None)

    def finish_training(self, *, by: str = "operator", use: str = "ask") -> TrainingOutcome:
        """Fit the library of the measured throws, check it (the regression's held-out error,
        leave-one-out; the area it covers: the hull of the measured landings), write it as a new
        version of the library folder (and to the file `train_to` named), compare it with the
        library in use, and end the run (its progress file goes once the library is saved). `use`
        (one of `USES`): "ask" leaves the new library waiting for `choose_trained_library`;
        "if_better" puts it in use only when the comparison says it is better; "always" puts it in
        use. `by`: who finished it ("operator", "command"), as the version records."""
        if use not in USES:
            raise AppError(f"finish_training's use is one of {USES}, got {use!r}")
        with self._training(Operation.TRAIN_FINISH) as run:
            world = self.world
            refused = first_implausible(run, world.arm_model, world.ball())
            if refused is not None:  # an edited file: that throw is failed, to retry or skip; nothing is fitted
                i, why = refused
                self._step(run.refused(i, why), f"training throw {i + 1}: {why}: retry or skip it")
                raise AppError(
                    f"training throw {i + 1}: {why}: it is no landing of that throw (was the progress file edited?); "
                    "it is marked failed: retry or skip it, then finish"
                )
            target = self.training_library  # the command's, never the progress file's
            library = library_of(run, world.arm_model, world.ball(), {"training_file": str(progress_path(target))})
            heldout = regression_leave_one_out_error(library, world.arm_model)
            if not np.isfinite(heldout.errors).all():
                raise AppError(
                    "a held-out throw never reaches its landing's height: the measured throws do not make a library; "
                    "retry the outliers or train over a smaller area"
                )
            planner = ThrowPlanner(world.arm_model, library)  # the fit the planner will use: it must build
            current, in_use = self.comparable_library()
            old_label = "none (no library of this arm yet)" if current is None else "the library in use"
            comparison = compare_libraries(
                library,
                current,
                world.arm_model,
                old_label=f"version {in_use.id} (in use)" if in_use is not None else old_label,
                new_refit=Heldout.of(heldout.errors, "refit"),
            )
            version = None
            if self._store is not None:
                version = self._store.add(
                    library, parent=in_use.id if in_use is not None else None, by=by, how="training",
                    note=f"{run.measured} throws over {run.area} ({run.skipped} skipped)",
                    calibration=self.calibration_fingerprint(), heldout=Heldout.of(heldout.errors, "refit"),
                )  # fmt: skip
            path = save_library(target, library) if self._training_library is not None else None
            with contextlib.suppress(FileNotFoundError):
                os.unlink(progress_path(target))
            written = path if path is not None else self._store.path(version.id)  # type: ignore[union-attr]
            outcome = TrainingOutcome(
                str(written),
                len(library),
                run.skipped,
                heldout.mean,
                heldout.median,
                heldout.max,
                planner.area.describe(),
                version=None if version is None else version.id,
                verdict=comparison.verdict(),
            )
            self._update(
                Event.TRAINING,
                training=None,
                training_preview=None,
                training_outcome=outcome,
                library_choice=LibraryChoice(library, outcome.version, comparison),
                message=f"trained library saved ({comparison.verdict()}): use it or keep the library in use",
            )
            if use == "always" or (use == "if_better" and comparison.better):
                self._settle_choice(True, by)
            elif use == "if_better":
                self._settle_choice(False, by)
        return self.snapshot().training_outcome or outcome
