"""Finish training ends with a choice, never a silent downgrade (issue 43, item 2): the new library
is a version of the folder, compared with the one in use on the figures both can be judged on;
"if_better" keeps the one in use and says why; the operator goes back to any version; a version
trained with another calibration says so in one line; a crash at any write of Finish leaves the
previous version in use and the run resumable. Kinematic world, true calibration, SimClock."""

from __future__ import annotations

import dataclasses
import os
import signal

import numpy as np
import pytest

from tests.app.test_library_store import Fault
from wiithrow.app.session import Operation, Session, simulated_session
from wiithrow.app.session.refusals import CHOOSE_FIRST, NO_CHOICE
from wiithrow.app.throws.library_compare import AREA_PER_THROW_M2, throws_needed
from wiithrow.app.throws.library_file import load_library
from wiithrow.app.throws.library_store import LibraryStore
from wiithrow.app.throws.training_file import progress_path
from wiithrow.throwing import Area

SMALL = Area((1.2, 1.4), (0.0, 0.2))


@pytest.fixture(scope="module")
def world():
    session = simulated_session(seed=3, calibration="true", quiet=True)
    yield session.world
    session.close()


def _trained(world, store: LibraryStore, count: int = 5) -> Session:
    """A session on `world` whose run of `count` throws over SMALL is measured, not finished."""
    session = Session(world, rng=np.random.default_rng(5), store=store)
    session.start_training(SMALL, count)
    for _ in range(count):
        session.training_throw(session.preview_training_throw().id)
        session.measure_training_landing()
    return session


def test_a_worse_library_is_compared_and_kept_out_of_use(world, tmp_path):
    store = LibraryStore(tmp_path / "library")
    session = _trained(world, store)
    shipped = session.library.to_dict()
    outcome = session.finish_training(use="if_better")
    choice = session.snapshot().library_choice
    assert choice is None and outcome.used is False and outcome.version == 1
    assert session.library.to_dict() == shipped and store.in_use_record() is None
    assert "is not better" in outcome.verdict and "its held-out error is worse" in outcome.verdict
    assert "covers" in outcome.verdict  # 0.2 m x 0.2 m of the shipped library's 0.6 m x 0.4 m
    assert session.last_message.startswith("kept the library in use; version 1 is kept in the library folder")
    info = store.info(1)
    assert info.how == "training" and info.by == "operator" and info.parent is None and info.throws == 5
    assert info.calibration == session.calibration_fingerprint() and info.heldout.method == "refit"


def test_the_operator_chooses_and_goes_back(world, tmp_path):
    store = LibraryStore(tmp_path / "library")
    session = _trained(world, store)
    shipped = session.library.to_dict()
    outcome = session.finish_training()  # "ask": the choice waits
    assert outcome.used is None and session.library.to_dict() == shipped
    assert session.refusal(Operation.TRAIN_START) == CHOOSE_FIRST
    assert session.refusal(Operation.LIBRARY_USE) == CHOOSE_FIRST
    comparison = session.snapshot().library_choice.comparison
    rows = {a: (b, c) for a, b, c in comparison.rows()}
    assert set(rows) >= {"held-out error, mean", "area covered", "throws (its area needs)"}
    assert comparison.old.throws == 25 and comparison.new.throws == 5
    session.choose_trained_library(True)
    assert session.refusal(Operation.LIBRARY_CHOOSE) == NO_CHOICE
    assert store.in_use_record().id == 1 and session.library_version.id == 1
    assert len(session.library) == 5
    # a throw joins the trained library: a learning version of it
    session.set_target(np.array([1.3 * np.cos(0.1), 1.3 * np.sin(0.1), 0.1]))
    assert session.align().converged
    record = session.throw(session.plan_preview().id)
    assert record.learned["used"] and store.info(record.learned["version"]).parent == 1
    # back to the shipped library's version: the learning version stays on disk
    store.add(
        load_library(), parent=None, by="command", how="import", note="the shipped library", calibration=None,
        heldout=None,
    )  # fmt: skip
    shipped_version = max(store.ids())
    session.use_version(shipped_version)
    assert session.library.to_dict() == shipped and store.in_use_record().id == shipped_version
    assert store.in_use_record().recent[-3:] == (1, record.learned["version"], shipped_version)


def test_a_library_trained_with_another_calibration_says_so_once(world, tmp_path):
    store = LibraryStore(tmp_path / "library")
    session = _trained(world, store)
    session.finish_training(use="always")
    assert session.library_version.calibration == session.calibration_fingerprint()
    true = world.calibration
    shifted = dataclasses.replace(true.cameras[0], P=true.cameras[0].P + np.array([[0, 0, 0, 1e-3]] + [[0] * 4] * 2))
    moved = dataclasses.replace(true, cameras=(shifted, *true.cameras[1:]))  # a camera moved a little
    assert moved.fingerprint != true.fingerprint
    session.use_calibration(moved)
    told = []
    session.subscribe(lambda event: told.append(session.last_message))
    session.set_target(np.array([1.3, 0.0, 0.1]))
    assert session.align().converged
    session.plan_preview()
    lines = [m for m in told if "trained with calibration" in m]
    assert len(set(lines)) == 1 and moved.fingerprint in lines[0]
    session.plan_preview()
    assert len({m for m in told if "trained with calibration" in m}) == 1  # once per pair


def test_the_throws_an_area_needs():
    from wiithrow.app.throws.library_store import AreaFigures

    paper = AreaFigures((1.0, 1.6), (0.0, 0.4), 0.24)
    assert throws_needed(paper) == 24 and throws_needed(None) == 5
    assert throws_needed(AreaFigures((1.2, 1.4), (0.0, 0.2), 0.04)) == 5
    assert pytest.approx(0.01) == AREA_PER_THROW_M2


def test_a_crash_at_every_write_of_finish_leaves_the_previous_version_in_use(world, tmp_path, monkeypatch):
    """SIGKILL at each step of Finish training (its version, the progress file's removal, the
    choice "always": the record of the version in use): a restart finds the previous version in use
    byte for byte, and the trained library still there (the run to finish, or its version), or the
    new version in use."""
    outcomes = set()
    at = 1
    while True:
        store = LibraryStore(tmp_path / f"{at}" / "library")
        store.add(load_library(), parent=None, by="command", how="import", note="shipped", calibration=None,
                  heldout=None, use=True)  # fmt: skip
        before = store.path(1).read_bytes()
        session = _trained(world, store)
        pid = os.fork()
        if pid == 0:
            try:
                Fault(monkeypatch, at, kill=True)
                session.finish_training(use="always")
                os._exit(0)
            except BaseException:
                os._exit(3)
        _, status = os.waitpid(pid, 0)
        finished = os.WIFEXITED(status)
        assert (finished and os.WEXITSTATUS(status) == 0) or os.WTERMSIG(status) == signal.SIGKILL, status
        again = LibraryStore(store.folder)
        in_use = again.in_use_record().id
        assert store.path(1).read_bytes() == before
        again.in_use()  # reads
        restarted = Session(world, rng=np.random.default_rng(5), store=again)
        run = restarted.resume_training()
        if in_use == 1:  # the trained library is never lost: the run to finish again, or its version
            kept = 2 in again.ids() and again.info(2).how == "training" and again.info(2).throws == 5
            assert (run is not None and run.complete) or kept, "the trained library was lost"
            outcomes.add("previous, run resumable" if run is not None else "previous, new version kept")
        else:
            assert in_use == 2 and again.info(2).how == "training"
            outcomes.add("new" + (", run left" if run is not None else ""))
        if finished:
            assert not progress_path(restarted.training_library).exists() and in_use == 2
            break
        at += 1
    print(f"\nFinish killed at each of {at - 1} write steps: {sorted(outcomes)}")
    assert at > 8 and "previous, run resumable" in outcomes and "new" in outcomes
