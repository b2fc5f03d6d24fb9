"""Training from the dashboard, below the dashboard: the `TrainingRun` state machine and its file
(save, resume, retry, skip), the area bounded by the arm's reach, and the session's training
operations on the kinematic world: each step's refusal, a Stop mid-throw that leaves the run at
that throw, a restart (a new session on the same progress file) that resumes it, and a finish that
saves a library and throws with it."""

from __future__ import annotations

import json

import numpy as np
import pytest

from wiithrow.app.errors import AppError
from wiithrow.app.session import Event, Operation, Session, simulated_session
from wiithrow.app.throws.library_file import load_library
from wiithrow.app.throws.safe_stop import ThrowFailed
from wiithrow.app.throws.training_file import TrainingFileError, load_run, progress_path, save_run
from wiithrow.app.throws.training_run import (
    MIN_MEASURED,
    Measurement,
    TrainingRun,
    reachable_area,
    training_targets_for,
)
from wiithrow.throwing import Area, ThrowParameters, training_targets

AREA = Area((1.0, 1.6), (0.0, 0.4))
SMALL = Area((1.2, 1.5), (0.0, 0.3))
RIG = Measurement("rig", "0123456789abcdef", "link1", "2025-01-01T00:00:00+00:00")


def params(n: int = 3) -> ThrowParameters:
    return ThrowParameters(np.linspace(0.1, 0.3, n), np.linspace(1.0, 2.0, n))


def test_the_targets_are_the_papers_grid_for_25_and_cover_the_corners_for_fewer():
    assert np.allclose(training_targets_for(AREA, 25), training_targets(AREA))
    for count in (4, 6, 7, 12):
        T = training_targets_for(AREA, count)
        assert T.shape == (count, 2) and len({tuple(t) for t in T}) == count
        for corner in ((1.0, 0.0), (1.0, 0.4), (1.6, 0.0), (1.6, 0.4)):
            assert np.min(np.linalg.norm(T - corner, axis=1)) < 1e-9
        assert (T[:, 0] >= 1.0).all() and (T[:, 0] <= 1.6).all() and (T[:, 1] >= 0).all() and (T[:, 1] <= 0.4).all()


def test_a_run_steps_through_its_throws_and_its_file_resumes_it(tmp_path):
    run = TrainingRun.start("pa10", AREA, 6)
    assert run.index == 0 and run.progress_line() == "throw 1/6 · measured 0 · skipped 0"
    run = run.thrown(params(), [1.0, 0.0, 0.0])
    assert run.progress_line() == "throw 1/6 (thrown) · measured 0 · skipped 0"
    with pytest.raises(AppError, match="thrown, not pending"):
        run.thrown(params(), None)
    run = run.retried()  # what it did is forgotten
    assert run.current is not None and run.current.state == "pending" and run.current.params is None
    assert run.thrown(params(), None, 0.004).current.release_warning == ""  # the kinematic world's jitter
    late = run.thrown(params(), None, 0.12).current
    assert late.release_warning.startswith("the hand was told to open 120 mm from the planned release")
    run = run.thrown(params(), None, 0.05).landed([1.01, 0.0], RIG)
    run = run.skip()
    run = run.failed("stopped by the operator")
    assert run.index == 2 and run.current is not None and run.current.note == "stopped by the operator"
    path = save_run(progress_path(tmp_path / "lib.json"), run)
    assert path.name == "lib.training.json"
    back = load_run(path, tmp_path / "lib.json")
    assert back is not None and back.to_dict() == run.to_dict()
    assert back.progress_line() == "throw 3/6 (failed) · measured 1 · skipped 1"
    assert np.allclose(back.throws[0].measured, [1.01, 0.0]) and back.throws[0].params is not None
    assert back.throws[0].release_off_m == 0.05 and "50 mm" in back.throws[0].release_warning
    assert load_run(tmp_path / "none.training.json", tmp_path / "none.json") is None


def test_a_broken_progress_file_is_named_and_left_alone(tmp_path):
    path = tmp_path / "lib.training.json"
    run = TrainingRun.start("pa10", AREA, 5)
    document = json.loads(save_run(path, run).read_text())
    document["throws"][0]["state"] = "measured"  # a measured throw without its params or landing
    path.write_text(json.dumps(document))
    with pytest.raises(TrainingFileError, match="lib.training.json: a broken training run .*needs its params"):
        load_run(path, tmp_path / "lib.json")
    path.write_text("{not json")
    with pytest.raises(TrainingFileError, match="lib.training.json"):
        load_run(path, tmp_path / "lib.json")
    assert path.read_text() == "{not json"
    with pytest.raises(AppError, match="5 to 100"):
        TrainingRun.start("pa10", AREA, 4)
    with pytest.raises(AppError, match="at least 5 cm"):
        TrainingRun.start("pa10", Area((1.0, 1.6), (0.0, 0.01)), 6)


def test_the_area_is_bounded_by_the_arms_reach_at_the_velocity_margin(pa10):
    inside, notes = reachable_area(pa10, AREA)
    assert inside == AREA and notes == []
    bounded, notes = reachable_area(pa10, Area((1.0, 2.2), (0.0, 0.4)))
    # the PA-10's operator reaches 1.71 m at 0.4 m height (throwing/library.py's docstring)
    assert 1.68 <= bounded.x[1] <= 1.73 and bounded.x[0] == 1.0, bounded
    assert len(notes) == 1 and "reach at z 0.40 m" in notes[0]


@pytest.fixture(scope="module")
def trained_world(tmp_path_factory):
    """A session on the kinematic world with its true calibration (the world is shared by the
    module's sessions: a new `Session` on it is a restart of the server)."""
    session = simulated_session(seed=3, calibration="true", quiet=True)
    yield session
    session.close()


def test_training_in_the_session_stops_resumes_and_ends_with_the_library_in_use(trained_world, tmp_path):
    session = trained_world
    library_file = tmp_path / "trained.json"
    assert session.train_to(library_file) is None
    assert session.refusal(Operation.TRAIN_PREVIEW) == (
        "no training running: set the area and the number of throws, then press Start training"
    )
    run = session.start_training(SMALL, 6)
    assert run.count == 6 and session.snapshot().training == run
    assert progress_path(library_file).exists()
    assert session.refusal(Operation.TRAIN_START).startswith("training is under way (throw 1/6")
    assert session.refusal(Operation.TRAIN_THROW) == "preview training throw 1 first"
    assert session.refusal(Operation.TRAIN_MEASURE) == "throw 1 is not thrown yet: preview and throw it"
    assert session.refusal(Operation.TRAIN_RETRY) == "throw 1 has not been thrown: nothing to retry"
    assert (
        session.refusal(Operation.TRAIN_FINISH) == f"measure at least {MIN_MEASURED} throws before fitting (0 measured)"
    )

    def throw_and_measure() -> None:
        preview = session.preview_training_throw()
        session.training_throw(preview.id)
        assert session.refusal(Operation.TRAIN_PREVIEW).startswith("measure the landing of throw")
        session.measure_training_landing()

    throw_and_measure()
    throw_and_measure()
    # throw 3: a Stop while the arm winds up ends it safely; the run stays at throw 3, failed
    preview = session.preview_training_throw()

    def stop_once_thrown(event: Event) -> None:
        if event is Event.TRAINING and session.operation is Operation.TRAIN_THROW:
            session.unsubscribe(stop_once_thrown)
            session.stop()

    session.subscribe(stop_once_thrown)
    with pytest.raises(ThrowFailed):
        session.training_throw(preview.id)
    run = session.snapshot().training
    assert run is not None and run.index == 2 and run.current is not None and run.current.state == "failed"
    assert session.refusal(Operation.TRAIN_PREVIEW).startswith("throw 3 did not complete (")
    assert load_run(progress_path(library_file), library_file).to_dict() == run.to_dict()  # saved after the Stop
    session.home()

    # a restart: a new session on the same world and progress file takes the run up at throw 3
    restarted = Session(session.world, rng=np.random.default_rng(5))
    resumed = restarted.train_to(library_file)
    assert resumed is not None and resumed.to_dict() == run.to_dict()
    restarted.retry_training_throw()
    session = restarted
    throw_and_measure()
    preview = session.preview_training_throw()
    session.training_throw(preview.id)
    session.skip_training_throw()  # thrown, then left out: throw 4 is skipped unmeasured
    throw_and_measure()
    throw_and_measure()
    run = session.snapshot().training
    assert run is not None and run.complete and run.measured == 5 and run.skipped == 1
    assert session.refusal(Operation.TRAIN_PREVIEW) == "every training throw is done: press Finish training"

    before = session.library.to_dict()
    outcome = session.finish_training()
    assert outcome.throws == 5 and outcome.skipped == 1
    assert not progress_path(library_file).exists() and session.snapshot().training is None
    saved = load_library(library_file)
    # nothing is put in use without the operator's choice: the comparison waits for it
    assert outcome.used is None and session.library.to_dict() == before
    assert session.refusal(Operation.LIBRARY_CHOOSE) is None
    session.choose_trained_library(True)
    assert session.snapshot().training_outcome.used is True and session.snapshot().library_choice is None
    assert saved.to_dict() == session.library.to_dict()  # in use
    measured = [t.measured for t in run.throws if t.state == "measured"]
    assert np.allclose(saved.landings, measured)
    # the labels are the rig's measurements near their targets (true calibration: millimetres)
    assert np.max(np.linalg.norm(saved.landings - saved.targets, axis=1)) < 0.02
    # the regression's held-out error over 5 throws on a 0.3 m x 0.3 m area: stated bound 60 mm median
    assert 0 < outcome.heldout_median_m < 0.06 and outcome.heldout_max_m >= outcome.heldout_median_m
    assert "5 measured landings" in outcome.covers
    # the session plans with the new library inside its trained area
    throw = session.planner.plan((1.35, 0.15), q1=0.0)
    assert abs(throw.predicted.xz[0] - 1.35) < 0.03
