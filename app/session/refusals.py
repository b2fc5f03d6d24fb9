"""Each operation's precondition, written once: `refusal(op, state, world)` says why `op` may not
start now (a one-line `Refusal`), or None when it may.

Who asks (all through `Session.refusal`, which reads the state under the session's lock):

* the session itself, as each operation begins (atomically with marking it running: the reason
  is raised, `Busy` when another operation runs, else `AppError`);
* the dashboard, for every button's enabled state and the reason shown beside it
  (`wiithrow.web.controls.button_states`);
* the dashboard's server, before it starts anything for a click (a forged click whose
  precondition fails is refused with the same text).

The rules, in the order they are checked (the first that fails is the reason):

| operation | refused when |
|---|---|
| every one but Stop | another operation runs (`busy_reason`; moving the target is allowed while tracking) |
| Calibrate, wand, load a calibration | the rig's markers come from another host |
| Track, Measure landing, Training measure | the markers come from another host and no publisher is followed yet (`ChoosesSource.source_refused`) |
| Follow a marker source | the markers come from this host's remotes (`NO_SOURCE_TO_CHOOSE`) |
| Calibrate, Home, Track, Preview, Throw, Measure landing | the arm has no driver (`NO_ARM`) |
| Track target | the rig does not track (not calibrated) |
| Preview | no converged alignment; the target moved since |
| Throw | no hand (`NO_GRIPPER`); no preview |
| Measure landing | no throw yet; the last throw failed before the hand let go; the rig does not track |
| Move the target | the world cannot move it (a real IR source) |
| Start training, training preview, throw and measure | the arm has no driver (`NO_ARM`) |
| Start training | the rig does not track; a run is under way; a trained library waits for a choice (`CHOOSE_FIRST`) |
| every other training step | no run (`NO_TRAINING`) |
| Training preview | the current throw was thrown (measure it) or failed (retry or skip it); the run is complete |
| Training throw | no hand; no training preview |
| Training measure | the current throw is not thrown; the rig does not track |
| Retry | the current throw was neither thrown nor failed |
| Skip | the run is complete |
| Finish | the current throw was thrown and not measured; fewer than `MIN_MEASURED` throws measured |
| Choose library | no trained library waits for a choice (`NO_CHOICE`) |
| Use a library version | a trained library waits for a choice (`CHOOSE_FIRST`) |

Stop is never refused. What depends on a call's arguments (a preview id that is no longer
current, the robot frame of a wand calibration without an arm) or on a passing moment (the arm
still moving when a preview is asked for) is checked by the operation itself.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from wiithrow.app.errors import AppError
from wiithrow.app.network.source_pin import ChoosesSource
from wiithrow.app.session.operations import Operation, busy_reason
from wiithrow.app.session.records import SessionSnapshot
from wiithrow.app.throws.training_run import MIN_MEASURED, TrainingRun
from wiithrow.app.worlds import RigWorld
from wiithrow.app.worlds.base import NO_GRIPPER


class Busy(AppError):
    """Another operation is running; the request was refused without moving anything."""


#: Why the arm's operations are refused when the arm has no driver.
NO_ARM = "no arm driver: the arm is parked (the settings' arm_driver)"
CALIBRATE_FIRST = "calibrate first: the rig tracks markers once it is calibrated"
TRACK_FIRST = "track the target first: the throw is planned in the plane joint 1 aligned"
TARGET_MOVED = "the target moved: track it again"
PREVIEW_FIRST = "preview the throw first"
THROW_FIRST = "throw first: the landing of the last throw is measured"
NOTHING_LANDED = "the last throw failed before the hand let go of the ball: nothing landed to measure"
REAL_TARGET = "the target is a real IR source: the operator puts it where it should be"

NO_SOURCE_TO_CHOOSE = "the markers come from this host's remotes: there is no publisher to choose"

NO_TRAINING = "no training running: set the area and the number of throws, then press Start training"
TRAINING_COMPLETE = "every training throw is done: press Finish training"
CALIBRATE_TO_TRAIN = "calibrate first: training measures each landing with the rig"
NO_CHOICE = "no trained library waits for a choice: finish a training first"
CHOOSE_FIRST = "a trained library waits for your choice: use it or keep the library in use first"

#: The operations that move the arm or need it (refused with `NO_ARM` without a driver).
NEEDS_ARM = frozenset(
    {
        Operation.CALIBRATE,
        Operation.HOME,
        Operation.TRACK,
        Operation.PREVIEW,
        Operation.THROW,
        Operation.MEASURE_LANDING,
        Operation.TRAIN_START,
        Operation.TRAIN_PREVIEW,
        Operation.TRAIN_THROW,
        Operation.TRAIN_MEASURE,
    }
)
#: The steps of a training run (refused with `NO_TRAINING` when none is under way).
TRAINING_STEPS = frozenset(
    {
        Operation.TRAIN_PREVIEW,
        Operation.TRAIN_THROW,
        Operation.TRAIN_MEASURE,
        Operation.TRAIN_RETRY,
        Operation.TRAIN_SKIP,
        Operation.TRAIN_FINISH,
    }
)
#: The operations that calibrate the rig (refused when its markers come from another host).
CALIBRATES = frozenset({Operation.CALIBRATE, Operation.CALIBRATE_WAND, Operation.LOAD_CALIBRATION})
#: The operations that act on the markers (refused while no publisher of them is followed).
READS_MARKERS = frozenset({Operation.TRACK, Operation.MEASURE_LANDING, Operation.TRAIN_MEASURE})


@dataclass(frozen=True)
class Refusal:
    """Why an operation may not start: the one-line `reason`; `busy` when another one runs."""

    reason: str
    busy: bool = False

    def error(self) -> AppError:
        return Busy(self.reason) if self.busy else AppError(self.reason)


def refusal(op: Operation, state: SessionSnapshot, world: RigWorld) -> Refusal | None:
    """Why `op` may not start in `state` on `world`, or None (the rules of the module docstring)."""
    if op is Operation.STOP:
        return None
    running = state.operation
    if running is not None and not (op is Operation.MOVE_TARGET and running is Operation.TRACK):
        return Refusal(busy_reason(running), busy=True)
    if op in CALIBRATES:
        why = world.rig.calibration_refused()
        if why:
            return Refusal(why)
    if op in NEEDS_ARM and not world.arm_connected:
        return Refusal(NO_ARM)
    if op is Operation.FOLLOW_SOURCE and not isinstance(world.rig, ChoosesSource):
        return Refusal(NO_SOURCE_TO_CHOOSE)
    if op in READS_MARKERS and isinstance(world.rig, ChoosesSource) and (unfollowed := world.rig.source_refused()):
        return Refusal(unfollowed)
    why = _precondition(op, state, world)
    return Refusal(why) if why else None


def _precondition(op: Operation, state: SessionSnapshot, world: RigWorld) -> str:
    """The operation's own precondition ("" when it holds)."""
    tracking = world.tracks_markers
    if op is Operation.TRACK and not tracking:
        return CALIBRATE_FIRST
    if op is Operation.PREVIEW:
        if state.alignment is None or not state.alignment.converged:
            return TRACK_FIRST if tracking else CALIBRATE_FIRST
        if state.target_moved:
            return TARGET_MOVED
    if op is Operation.THROW:
        if world.gripper is None:
            return NO_GRIPPER
        if state.preview is None:
            return PREVIEW_FIRST
    if op is Operation.MEASURE_LANDING:
        if not state.history:
            return THROW_FIRST
        last = state.history[-1]
        if last.failure is not None and not np.isfinite(last.execution.t_release):
            return NOTHING_LANDED
        if not tracking:
            return CALIBRATE_FIRST
    if op is Operation.MOVE_TARGET and not world.simulated:
        return REAL_TARGET
    if op is Operation.TRAIN_START:
        if not tracking:
            return CALIBRATE_TO_TRAIN
        if state.training is not None:
            return f"training is under way ({state.training.progress_line()}): go on with it, or finish it"
    if op is Operation.LIBRARY_CHOOSE and state.library_choice is None:
        return NO_CHOICE
    if op in (Operation.LIBRARY_USE, Operation.TRAIN_START) and state.library_choice is not None:
        return CHOOSE_FIRST
    if op in TRAINING_STEPS:
        return _training_step(op, state, world, state.training)
    return ""


def _training_step(op: Operation, state: SessionSnapshot, world: RigWorld, run: TrainingRun | None) -> str:
    """The precondition of one step of a training run ("" when it holds)."""
    if run is None:
        return NO_TRAINING
    i, current = run.index, run.current
    n = (i or 0) + 1
    if op is Operation.TRAIN_FINISH:
        if current is not None and current.state == "thrown":
            return f"measure the landing of throw {n} first (or skip it)"
        if run.measured < MIN_MEASURED:
            return f"measure at least {MIN_MEASURED} throws before fitting ({run.measured} measured)"
        return ""
    if current is None:
        return TRAINING_COMPLETE
    if op is Operation.TRAIN_PREVIEW:
        if current.state == "thrown":
            return f"measure the landing of throw {n} first (or retry or skip it)"
        if current.state == "failed":
            return f"throw {n} did not complete ({current.note}): retry or skip it"
    if op is Operation.TRAIN_THROW:
        if world.gripper is None:
            return NO_GRIPPER
        if state.training_preview is None:
            return f"preview training throw {n} first"
    if op is Operation.TRAIN_MEASURE:
        if current.state != "thrown":
            return f"throw {n} is not thrown yet: preview and throw it"
        if not world.tracks_markers:
            return CALIBRATE_FIRST
    if op is Operation.TRAIN_RETRY and current.state not in ("thrown", "failed"):
        return f"throw {n} has not been thrown: nothing to retry"
    return ""
