"""A training run measured at once, for the tests of what `wiithrow train` does around its throws
(its flags, its output, its files): the command's throwing loop (`train.throw_the_run`) is replaced
by one that makes the session's run the shipped library's 25 throws, measured, saved to the run's
progress file as the session's steps save it. The throws themselves are tested in
tests/cli/test_train_run.py and tests/app/test_training_run.py."""

from __future__ import annotations

from wiithrow.app.session import Session
from wiithrow.app.throws.library_file import load_library
from wiithrow.app.throws.training_file import progress_path, save_run
from wiithrow.app.throws.training_run import Measurement, TrainingRun, TrainingThrow
from wiithrow.throwing import Area

#: The fingerprint recorded as what measured the shipped labels (16 hex digits, as a calibration's).
FINGERPRINT = "5b1ee0ed5b1ee0ed"


def shipped_run(session: Session, *args: object, **kwargs: object) -> TrainingRun:
    """`throw_the_run`'s stand-in: the session's run made of the shipped library's throws (all
    measured, over the area of their targets), saved beside the session's training library and
    resumed by the session."""
    run = session.snapshot().training
    assert run is not None
    library = load_library()
    by = Measurement.by_rig(FINGERPRINT, "link1")
    throws = tuple(
        TrainingThrow(t.target, "measured", t.params, None, t.landing, measured_by=by) for t in library.throws
    )
    # the shipped targets were placed with 1 cm of jitter: the run's area holds them all
    T = library.targets
    area = Area((float(T[:, 0].min()), float(T[:, 0].max())), (float(T[:, 1].min()), float(T[:, 1].max())))
    run = TrainingRun(run.arm, area, throws, run.notes)
    save_run(progress_path(session.training_library), run)
    session.resume_training()
    return run
