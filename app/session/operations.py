"""The session's vocabulary: what an operator can start (`Operation`) and what the session tells its
listeners changed (`Event`), one enum each, used by the session, the dashboard, the recorder and
the publisher alike (no operation or event is a string anywhere).

An `Operation` carries how it is named to a person: `title` (a notification's or the status line's
head: "Calibration", "Throw") and `doing` (what a busy session is doing: "calibrating with the
robot"). `busy_reason(op)` is the one text of "an operation runs" (`Session.refusal` and the
dashboard's operation runner both say it).
"""

from __future__ import annotations

import enum


class Operation(enum.Enum):
    """What an operator can start, one at a time (Stop is always allowed and never refused)."""

    CALIBRATE = ("Calibration", "calibrating with the robot")
    CALIBRATE_WAND = ("Wand calibration", "calibrating with the wand")
    LOAD_CALIBRATION = ("Calibration", "loading a calibration")
    CHANGE_PLANNER = ("Throw library", "changing the throw library")
    MOVE_TARGET = ("Target", "moving the target")
    TRACK = ("Track target", "tracking the target (turning joint 1 to it)")
    PREVIEW = ("Preview", "previewing the throw")
    THROW = ("Throw", "throwing")
    MEASURE_LANDING = ("Measure landing", "measuring the landing")
    HOME = ("Home", "moving the arm home")
    FOLLOW_SOURCE = ("Marker source", "switching to another marker source")
    # training from the dashboard (`wiithrow.app.session.training`): one step of the run each; the
    # titles are the Training panel's button labels
    TRAIN_START = ("Start training", "starting the training (checking the area against the arm's reach)")
    TRAIN_PREVIEW = ("Preview training throw", "previewing a training throw")
    TRAIN_THROW = ("Throw (training)", "throwing a training throw")
    TRAIN_MEASURE = ("Measure training landing", "measuring a training throw's landing")
    TRAIN_RETRY = ("Retry throw", "setting a training throw up again")
    TRAIN_SKIP = ("Skip throw", "skipping a training throw")
    TRAIN_FINISH = ("Finish training", "fitting, checking and saving the trained library")
    # the library in use (`wiithrow.app.session.library_use`)
    LIBRARY_CHOOSE = ("Choose library", "putting the chosen library in use")
    LIBRARY_USE = ("Use this version", "putting a library version in use")
    STOP = ("Stop", "stopping")

    def __init__(self, title: str, doing: str) -> None:
        self.title = title
        self.doing = doing


class Event(enum.Enum):
    """What changed in the session (a listener's argument; `Session.subscribe`)."""

    OPERATION = "an operation started or ended"
    PROGRESS = "the running operation's progress"
    MESSAGE = "the status message"
    CALIBRATION = "the rig's calibration"
    ALIGNMENT = "the alignment of joint 1"
    PREVIEW = "the throw preview"
    THROW = "a throw, or its landing measured"
    STOP = "Stop was pressed"
    TARGET = "the simulated target moved"
    HOME = "the arm went home"
    PLANNER = "the throw library or planner"
    TRAINING = "the training run: a step, its preview, its end"


def busy_reason(running: Operation | None) -> str:
    """Why nothing else may start while `running` runs (None: an operation not yet named)."""
    what = running.doing if running is not None else "another operation runs"
    return f"busy: {what}; wait for it to finish or press Stop"
