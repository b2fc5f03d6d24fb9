"""The training progress file decides nothing about where files go, and what it says was measured
is checked before it becomes a library.

A progress file (`<library>.training.json`) sits in the lab's folder beside the library the
session was told to write (`--train-to`); anyone who can edit it must not be able to make the
session write elsewhere (the file used to name the library, and its `library` field chose where
each step saved and what Finish replaced), nor turn fabricated "measured" landings into the library
in use. The session's runs are on the kinematic world, the true calibration (as
`test_training_run.py`)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from wiithrow.app.errors import AppError
from wiithrow.app.session import Session, simulated_session
from wiithrow.app.throws.landing_checks import LANDING_AREA_MARGIN_M, LANDING_PREDICTION_BOUND_M
from wiithrow.app.throws.library_file import load_library
from wiithrow.app.throws.training_file import TrainingFileError, load_run, progress_path, save_run
from wiithrow.app.throws.training_run import TrainingRun
from wiithrow.throwing import Area, ThrowParameters

SMALL = Area((1.2, 1.5), (0.0, 0.3))
PRECIOUS = '{"precious": "a lab file the training must never touch"}\n'


@pytest.fixture(scope="module")
def world_session():
    session = simulated_session(seed=3, calibration="true", quiet=True)
    yield session
    session.close()


@pytest.fixture(scope="module")
def measured_run(world_session, tmp_path_factory):
    """A run of 5 throws, each thrown and measured on the kinematic world, not finished: the
    progress file's text and the folder it was trained in."""
    lab = tmp_path_factory.mktemp("lab")
    session = Session(world_session.world, rng=np.random.default_rng(5))
    session.train_to(lab / "trained.json")
    session.start_training(SMALL, 5)
    for _ in range(5):
        preview = session.preview_training_throw()
        session.training_throw(preview.id)
        session.measure_training_landing()
    run = session.snapshot().training
    assert run is not None and run.complete and run.measured == 5
    return progress_path(lab / "trained.json").read_text()


def _files(folder: Path) -> set[str]:
    return {p.name for p in folder.iterdir()}


def test_a_progress_file_naming_another_file_is_refused_and_that_file_is_untouched(
    world_session, measured_run, tmp_path
):
    victim = tmp_path / "victim.json"
    victim.write_text(PRECIOUS)
    lab = tmp_path / "lab"
    lab.mkdir()
    library = lab / "trained.json"
    document = json.loads(measured_run)
    document["schema"], document["library"] = 1, str(victim)  # the old format, which named the library
    progress_path(library).write_text(json.dumps(document))
    session = Session(world_session.world, rng=np.random.default_rng(5))
    refused: str | None = None
    try:
        session.train_to(library)
        session.finish_training()  # the run is complete: Finish fits and saves
    except (AppError, TrainingFileError) as exc:
        refused = str(exc)
    assert victim.read_text() == PRECIOUS  # never written, whatever happened
    assert refused is not None, "a progress file that names another library was resumed"
    assert "\n" not in refused and str(victim) in refused and str(library) in refused, refused
    assert _files(lab) == {"trained.training.json"}  # nothing written in the lab's folder either


def test_the_library_and_its_progress_go_only_where_the_command_said(world_session, measured_run, tmp_path):
    victim = tmp_path / "victim.json"
    victim.write_text(PRECIOUS)
    lab = tmp_path / "lab"
    lab.mkdir()
    library = lab / "trained.json"
    progress_path(library).write_text(measured_run)  # the run, as the session wrote it
    written = json.loads(measured_run)
    assert "library" not in written, "the progress file still names a path"
    session = Session(world_session.world, rng=np.random.default_rng(5))
    assert session.train_to(library) is not None
    outcome = session.finish_training()
    assert Path(outcome.path) == library and load_library(library).arm == "pa10"
    assert _files(lab) == {"trained.json"}  # the library; its progress file went once it was saved
    assert victim.read_text() == PRECIOUS


def test_a_new_progress_file_with_a_library_field_is_refused(measured_run, tmp_path):
    path = tmp_path / "trained.training.json"
    document = json.loads(measured_run)
    document["library"] = str(tmp_path / "trained.json")
    path.write_text(json.dumps(document))
    with pytest.raises(TrainingFileError, match=r"unknown key\(s\) \['library'\]") as err:
        load_run(path, tmp_path / "trained.json")
    assert "\n" not in str(err.value)


def _tampered(measured_run: str, throw: int, measured: object) -> str:
    document = json.loads(measured_run)
    document["throws"][throw]["measured"] = measured
    return json.dumps(document)


@pytest.mark.parametrize(
    "case, reason",
    [
        ("1 m off", f"outside the training area x 1.20-1.50 m, z 0.00-0.30 m by more than {LANDING_AREA_MARGIN_M:g} m"),
        ("0.29 m higher, inside the area", f"from its predicted landing (at most {LANDING_PREDICTION_BOUND_M:g} m"),
        ("far outside the area", "outside the training area x 1.20-1.50 m, z 0.00-0.30 m by more than"),
    ],
)
def test_a_fabricated_landing_is_refused_before_the_fit_saying_which_throw_and_why(
    world_session, measured_run, tmp_path, case, reason
):
    document = json.loads(measured_run)
    throw = next(i for i, t in enumerate(document["throws"]) if t["target"][1] == 0.0)  # one on the floor
    x, z = document["throws"][throw]["measured"]
    measured = {"1 m off": [x + 1.0, z], "0.29 m higher, inside the area": [x, z + 0.29]}.get(case, [1.35, 9.0])
    library = tmp_path / "trained.json"
    progress_path(library).write_text(_tampered(measured_run, throw, measured))
    session = Session(world_session.world, rng=np.random.default_rng(5))
    session.train_to(library)
    with pytest.raises(AppError) as err:
        session.finish_training()
    message = str(err.value)
    assert message.startswith(f"training throw {throw + 1}: its measured landing") and reason in message, message
    assert "\n" not in message
    assert not library.exists()  # nothing was fitted or written
    run = session.snapshot().training  # the run stays, at that throw, failed: retry or skip it
    assert run is not None and run.index == throw and run.current is not None and run.current.state == "failed"
    assert load_run(progress_path(library), library).to_dict() == run.to_dict()


def test_a_non_finite_landing_is_refused_as_the_file_loads(measured_run, tmp_path):
    path = tmp_path / "trained.training.json"
    path.write_text(_tampered(measured_run, 0, [float("nan"), 0.1]))  # the NaN token
    with pytest.raises(TrainingFileError, match="throw 1: measured must be 2 finite numbers") as err:
        load_run(path, tmp_path / "trained.json")
    assert "\n" not in str(err.value)


def test_a_measured_throw_records_what_measured_it(measured_run):
    document = json.loads(measured_run)
    for throw in document["throws"]:
        by = throw["measured_by"]
        assert by["source"] == "rig" and by["frame"] == "link1"
        assert len(by["calibration"]) == 16 and int(by["calibration"], 16) >= 0  # the calibration's fingerprint
        assert by["time"].endswith("+00:00")  # when, in UTC


@pytest.mark.parametrize(
    "change, needle",
    [
        (lambda d: d["throws"][0].update(target=[1e300, 0.0]), "throw 1: target"),
        (lambda d: d["area"].update(x_m=[1.0, 1e9]), "area"),
        (lambda d: d["throws"][0].update(release_off_m=1e12), "throw 1: release_off_m"),
        (lambda d: d["throws"][0].update(note="x" * 5000), "throw 1: note"),
        (lambda d: d["throws"][0]["measured_by"].update(source="a rumour"), "throw 1: measured_by.source"),
        (
            lambda d: d["throws"][0].update(params={"q_release": [1e200, 0, 0], "dq_release": [1, 1, 1]}),
            "throw 1: params.q_release",
        ),
    ],
)
def test_the_progress_files_numbers_are_range_checked_as_it_loads(measured_run, tmp_path, change, needle):
    path = tmp_path / "trained.training.json"
    document = json.loads(measured_run)
    change(document)
    path.write_text(json.dumps(document))
    with pytest.raises(TrainingFileError) as err:
        load_run(path, tmp_path / "trained.json")
    assert needle in str(err.value) and "\n" not in str(err.value), str(err.value)


def test_an_old_progress_file_is_read_when_it_names_its_own_library(tmp_path):
    """Schema 1 named the library: read when that is the library beside it, refused otherwise."""
    library = tmp_path / "lib.json"
    run = TrainingRun.start("pa10", Area((1.0, 1.6), (0.0, 0.4)), 6)
    run = run.thrown(ThrowParameters(np.array([0.1, 0.2, 0.3]), np.array([1.0, 1.5, 2.0])), None)
    path = save_run(progress_path(library), run)
    old = json.loads(path.read_text())
    old["schema"] = 1
    old["library"] = str(library)
    for throw in old["throws"]:
        del throw["measured_by"]  # schema 1 did not record it
    path.write_text(json.dumps(old))
    back = load_run(path, library)
    assert back is not None and back.to_dict()["throws"] == run.to_dict()["throws"]
    old["library"] = str(tmp_path / "elsewhere.json")
    path.write_text(json.dumps(old))
    with pytest.raises(TrainingFileError, match="names the library .*elsewhere.json.*not .*lib.json"):
        load_run(path, library)
