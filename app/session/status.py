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

`throw_outcome(record)`: a throw's outcome in a few words: its measured error in 3D, the total
on the landing surface and its parts along and across the throw ("error 1.6 cm (along +0.3,
across -1.5)": `throwing.landing_error.LandingError.words`), or why there is no
figure: "failed ..." / "stopped ..." (it ended early, or was stopped after the release: its
`failure`; a host-timed release the host got to too late says "... the hand kept the ball"),
"lost in the wind-up: the ball left the hand N s before the release ..." (a ball the hand lost
before the release, `ThrowRecord.ball_lost`),
"not measured" (on hardware, until *Measure landing*); a late release says so first ("late
release (N ms after its time, bound 10 ms): error ... cm, kept out of the library"). Never "nan".
"""

from __future__ import annotations

import numpy as np

from wiithrow.app.session.operations import Operation
from wiithrow.app.session.records import SessionSnapshot, ThrowRecord
from wiithrow.app.throws.release_timing import RELEASE_LATE_BOUND_S

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


def throw_outcome(record: ThrowRecord) -> str:
    """A throw's outcome in a few words (see the module docstring)."""
    if record.ball_lost:
        before = record.ball_lost_before_s
        when = "before" if before is None else f"{before:.2f} s before"
        return f"lost in the wind-up: the ball left the hand {when} the release; kept out of the library"
    if record.failure is not None:
        return record.failure.removeprefix("the throw ")
    error = record.error
    figure = f"error {error.words('cm')}" if np.isfinite(error.total_m) else "not measured"
    late = record.execution.release_late_s
    if late is not None:
        return (
            f"late release ({1e3 * late:.0f} ms after its time, bound {1e3 * RELEASE_LATE_BOUND_S:.0f} ms): "
            f"{figure}, kept out of the library"
        )
    return figure
