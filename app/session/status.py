"""What the session's state says in words, written once for every view: the one calibration state
and a throw's outcome.

`calibration_state(state, calibrated)` is the rig's calibration as one phrase, whoever shows it
(the dashboard's status line and its Calibration folder, `Session.calibration_state`):

* a robot calibration running: its progress, "calibrating: pose k/N" (never "not calibrated"
  beside it: `CALIBRATING` until the first pose is in);
* a wand calibration running: "calibrating with the wand: p %";
* else whether the rig tracks with a calibration (`calibrated`: the world's, which a calibration
  loaded from a file or replayed from a recording sets without a robot calibration's figures in
  the state) and which: "calibrated with the robot (N poses)", "calibrated with a wand",
  "calibrated (loaded: ...)", or "not calibrated".

`throw_outcome(record)`: a throw's outcome in a few words: its one error figure (`error_figure`),
in `ERROR_UNIT`, the total on the landing surface and its parts along and across the throw, and who
measured it ("error 16.2 mm (along +3.0, across -15.0), measured by the rig", "... measured anew by
the rig (Measure landing)": `throwing.landing_error.LandingError.words`), or why there is no
figure: "failed ..." / "stopped ..." (it ended early, or was stopped after the release: its
`failure`; a host-timed release the host got to too late says "... the hand kept the ball"),
"lost in the wind-up: the ball left the hand N s before the release ..." (a ball the hand lost
before the release, `ThrowRecord.ball_lost`), `BEFORE_MEASURING` (on hardware, until *Measure
landing*); a late release says so first ("late release (N ms after its time, bound 10 ms): error
... mm, ..., kept out of the library"). Never "nan". `measured_again_line`: the session's message
after *Measure landing*, which says why its figure differs from the one measured at the landing.
"""

from __future__ import annotations

import numpy as np

from wiithrow.app.session.operations import Operation
from wiithrow.app.session.records import SessionSnapshot, ThrowRecord
from wiithrow.app.throws.release_timing import RELEASE_LATE_BOUND_S
from wiithrow.throwing.landing_error import PER_METRE, LandingError

#: The calibration's state before its first pose is in.
CALIBRATING = "calibrating: moving to the first pose"
#: The progress message of a robot calibration after `done` of `total` poses.
CALIBRATING_POSE = "calibrating: pose {done}/{total}"
NOT_CALIBRATED = "not calibrated"
#: A throw stopped after its release (its `failure`): the ball flew, the arm braked in its
#: follow-through; the record keeps where it landed, its outcome says stopped, with no figure.
STOPPED_AFTER_RELEASE = (
    "stopped by the operator after the release: the arm braked in its follow-through, the landing is not scored"
)
#: The unit of every throw's landing error the operator reads (the dashboard's label, table, status
#: and notifications; the Training panel): one unit, whoever shows it.
ERROR_UNIT = "mm"
#: `ERROR_UNIT`s in a metre.
ERROR_PER_M = PER_METRE[ERROR_UNIT]
#: A throw's outcome before its landing is measured (on hardware, until *Measure landing*).
BEFORE_MEASURING = "before measuring: no error yet (Measure landing)"
#: A calibration the rig tracks with that the session did not make (a file, a recording).
LOADED = "calibrated (loaded: its per-pose figures are not in this session)"


def calibration_state(state: SessionSnapshot, calibrated: bool) -> str:
    """The rig's calibration in one phrase (see the module docstring); `calibrated`: the rig
    tracks with a calibration now (`RigWorld.calibration is not None`)."""
    message = state.progress[0]
    if state.operation is Operation.CALIBRATE:
        return message if message.startswith("calibrating") else CALIBRATING
    if state.operation is Operation.CALIBRATE_WAND:
        done = state.progress[1]
        return f"calibrating with the wand: {100 * done:.0f} %"
    if not calibrated:
        return NOT_CALIBRATED
    if state.calibration is not None:
        return f"calibrated with the robot ({len(state.calibration.data)} poses)"
    if state.wand is not None:
        return "calibrated with a wand"
    return LOADED


def error_figure(record: ThrowRecord) -> str | None:
    """The throw's one error figure, in `ERROR_UNIT`, with who measured it: "error 10.4 mm (along
    +3.0, across -9.9), measured by the rig" (at the landing), "..., measured anew by the rig
    (Measure landing)"; None before the landing is measured."""
    error = record.error
    if not np.isfinite(error.total_m):
        return None
    by = "measured anew by the rig (Measure landing)" if record.measured_again else "measured by the rig"
    return f"error {error.words(ERROR_UNIT)}, {by}"


def measured_again_line(record: ThrowRecord, before: LandingError) -> str:
    """The session's message after *Measure landing* (`record` measured now, `before` its error
    until then): the new figure, and why it differs from the one measured at the landing."""
    figure = f"error {record.error.words(ERROR_UNIT)}"
    if not before.known:
        return f"landing of throw {record.index} measured by the rig: {figure}"
    return (
        f"landing of throw {record.index} measured anew by the rig: {figure}; at the landing it measured "
        f"{ERROR_PER_M * before.total_m:.1f} {ERROR_UNIT} (each look at the marker differs by the rig's noise)"
    )


def throw_outcome(record: ThrowRecord) -> str:
    """A throw's outcome in a few words (see the module docstring)."""
    if record.ball_lost:
        before = record.ball_lost_before_s
        when = "before" if before is None else f"{before:.2f} s before"
        return f"lost in the wind-up: the ball left the hand {when} the release; kept out of the library"
    if record.failure is not None:
        return record.failure.removeprefix("the throw ")
    figure = error_figure(record) or BEFORE_MEASURING
    late = record.execution.release_late_s
    if late is not None:
        return (
            f"late release ({1e3 * late:.0f} ms after its time, bound {1e3 * RELEASE_LATE_BOUND_S:.0f} ms): "
            f"{figure}, kept out of the library"
        )
    return figure
