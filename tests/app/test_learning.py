"""The session's library that keeps learning (issue 22, item 3): a measured throw joins it once,
each update is a new version of the library folder (the file the library came from is never
written), `--no-learn` (and the toggle) add none, a recording's `/throws` says what the update did,
and a 15 ms drift of the hand's release, injected through the world, is followed within 10
measured throws."""

from __future__ import annotations

import json
import shutil

import numpy as np
import pytest
from mcap.reader import make_reader

from tests.helpers.sim_fixtures import target_at
from wiithrow.app.recording.session import SessionRecorder
from wiithrow.app.session import simulated_session
from wiithrow.app.studies.compensation import random_targets, throw_at
from wiithrow.app.throws.library_file import default_library_path
from wiithrow.app.throws.library_store import LibraryStore
from wiithrow.throwing.online import META_KEY


@pytest.fixture
def library_file(tmp_path):
    path = tmp_path / "library.json"
    shutil.copyfile(default_library_path(), path)
    return path


def _throw(session, distance: float, height: float, azimuth: float):
    session.set_target(target_at(distance, azimuth, height))
    assert session.align().converged
    return session.throw(session.plan_preview().id)


def test_each_measured_throw_joins_once_and_each_update_is_a_version(library_file, tmp_path):
    store = LibraryStore(tmp_path / "folder")
    before = library_file.read_bytes()
    session = simulated_session(seed=3, calibration="true", quiet=True, library=library_file, store=store)
    first = _throw(session, 1.3, 0.2, 0.1)
    assert (
        first.learned is not None
        and first.learned["joined"] == 1
        and first.learned["source"] == "simulated measurement"
    )
    assert first.learned["saved_to"] == str(store.path(first.learned["version"])) and first.learned["refit_ms"] > 0
    assert library_file.read_bytes() == before  # the file it came from is never written
    imported, update = store.versions()
    assert imported.how == "import" and update.how == "learning" and update.parent == imported.id
    history = json.loads(store.path(update.id).read_text())["library"]["meta"][META_KEY]["history"]
    assert len(history) == 1 and history[0]["joined"] == 1
    np.testing.assert_allclose(history[0]["throw"]["landing"], first.landing_xz)
    session.measure_landing()  # measured again: the throw has joined already, nothing joins twice
    assert len(store.versions()) == 2
    second = _throw(session, 1.45, 0.0, -0.1)
    assert second.learned is not None and second.learned["joined"] == 2
    assert len(store.versions()) == 3 and store.in_use_record().id == second.learned["version"]
    assert len(session.learning_library.online.history) == 2
    # a session started from the folder resumes the same regression
    _, resumed = store.in_use()
    assert resumed.meta[META_KEY]["joined"] == session.learning_library.online.joined.tolist()
    session.close()


def test_no_learn_and_the_toggle_add_no_version(library_file, tmp_path):
    store = LibraryStore(tmp_path / "folder")
    before = library_file.read_bytes()
    session = simulated_session(seed=3, calibration="true", quiet=True, library=library_file, learn=False, store=store)
    assert not session.learning and len(store.versions()) == 1  # the file, kept as a version
    record = _throw(session, 1.3, 0.2, 0.1)
    assert record.learned is None and len(store.versions()) == 1
    session.set_learning(True)
    assert session.learning and _throw(session, 1.2, 0.1, 0.0).learned is not None
    session.set_learning(False)
    assert len(store.versions()) == 2 and _throw(session, 1.4, 0.3, 0.0).learned is None
    assert len(store.versions()) == 2 and library_file.read_bytes() == before
    session.close()


def test_the_update_is_in_the_recording(tmp_path):
    session = simulated_session(seed=5, calibration="true", quiet=True)
    path = tmp_path / "session.mcap"
    recorder = SessionRecorder(session, path)
    recorder.begin()
    record = _throw(session, 1.3, 0.35, 0.1)
    recorder.close()
    session.close()
    with path.open("rb") as f:
        throws = [json.loads(m.data) for _, c, m in make_reader(f).iter_messages() if c.topic == "/throws"]
    learning = throws[-1]["record"]["outcome"]["learning"]
    assert learning == json.loads(json.dumps(record.learned)) and learning["joined"] == 1
    assert learning["library_size"] == 25 - len(learning["retired"]) + 1 and learning["saved_to"] is None


@pytest.mark.slow
def test_a_release_latency_drift_is_followed():
    """A small seeded `wiithrow bench learning`: 8 probe throws, the hand 15 ms late, 10 measured
    throws joining. Measured (seed 0): median 3.6 mm before, 12.0 mm after the drift, 5.0 mm after
    10 throws; the goal is within 10 mm of the pre-drift median, and below the drift's own."""
    session = simulated_session(seed=0, calibration="true", quiet=True)
    probes = random_targets(8, np.random.default_rng(1))
    session.set_learning(False)
    before = float(np.nanmedian(throw_at(session, probes)))
    session.world.drift(release_latency_s=0.015)
    drifted = float(np.nanmedian(throw_at(session, probes)))
    session.set_learning(True)
    throw_at(session, random_targets(10, np.random.default_rng(2)))
    assert sum(r.learned is not None for r in session.history) == 10
    session.set_learning(False)
    after = float(np.nanmedian(throw_at(session, probes)))
    print(
        f"\nmedian error: {1e3 * before:.1f} mm, drifted {1e3 * drifted:.1f} mm, after 10 throws {1e3 * after:.1f} mm"
    )
    assert drifted > before + 0.003  # the drift is there
    assert after <= before + 0.010 and after < drifted - 0.002
    session.close()


def test_a_library_folder_that_cannot_be_written_loses_no_throw(tmp_path):
    store = LibraryStore(tmp_path / "gone")
    session = simulated_session(seed=3, calibration="true", quiet=True, store=store)
    (tmp_path / "gone").write_text("something else took the folder's place\n")
    record = _throw(session, 1.3, 0.2, 0.1)
    assert record.learned is not None and record.learned["saved_to"] is None and record.learned["used"]
    assert "could not be saved" in record.learned["save_error"] and str(store.folder) in record.learned["save_error"]
    assert session.history[-1] is record and len(session.learning_library.online.history) == 1
    session.close()
