"""`wiithrow library` and where libraries live (issue 43, items 1, 4 and 5): list, show, use (go
back), diff and move a library folder, with `--json`; the folder the settings name (relative to the
settings file), beside the calibration, or a simulated world's own; the old cache file read once;
`train --use-if-better`; a calibration that is replaced kept beside, its figures printed."""

from __future__ import annotations

import json
import shutil

import numpy as np
import pytest

from tests.helpers.strict_json import loads_strict
from wiithrow.app.calibration.point_files import write_calibration_points
from wiithrow.app.cli.main import main
from wiithrow.app.session.library_folder import OLD_CACHE_NAME, SIM_LIBRARIES_ENV, library_folder
from wiithrow.app.throws.library_file import default_library_path, load_library
from wiithrow.app.throws.library_store import LibraryStore
from wiithrow.vision.rig import observe_all, points_in_common_view, stereo_rig


@pytest.fixture()
def folder(tmp_path):
    """A library folder: the shipped library (version 1), and 6 of its throws over the same area (2, in use)."""
    store = LibraryStore(tmp_path / "lab" / "pa10-library")
    shipped = load_library()
    sparse = tuple(shipped.throws[i] for i in (0, 4, 20, 24, 12, 6))  # the corners, the middle and one more
    smaller = type(shipped)(shipped.arm, shipped.shape, shipped.ball, sparse, {"note": "6 throws"})
    for library, use in ((shipped, False), (smaller, True)):
        store.add(library, parent=None, by="command", how="import", note="test", calibration="0123456789abcdef",
                  heldout=None, use=use)  # fmt: skip
    return store


def _json(capsys, argv: list[str]):
    assert main(argv) == 0, capsys.readouterr().err
    return loads_strict(capsys.readouterr().out)


def test_list_show_use_and_diff(folder, capsys):
    where = ["--folder", str(folder.folder)]
    listed = _json(capsys, ["library", "list", *where, "--json"])
    assert listed["in_use"] == 2 and [v["id"] for v in listed["versions"]] == [1, 2]
    assert [v["in_use"] for v in listed["versions"]] == [False, True] and listed["versions"][1]["throws"] == 6
    assert main(["library", "list", *where]) == 0
    text = capsys.readouterr().out
    assert "in use: 2" in text and "import (command)" in text
    shown = _json(capsys, ["library", "show", "1", *where, "--json"])
    assert shown["made"]["how"] == "import" and shown["library"]["throws"] == 25
    diff = _json(capsys, ["library", "diff", "1", *where, "--json"])  # against the one in use
    assert diff["b"] == 2 and diff["comparison"]["better"] is True and diff["throws"]["shared"] == 6
    assert diff["comparison"]["in_use"]["throws_needed"] == 25  # 6 throws over the whole area
    assert main(["library", "diff", "2", "1", *where]) == 0
    text = capsys.readouterr().out
    assert "version 2 is not better" in text and "fewer than its area needs" in text
    used = _json(capsys, ["library", "use", "1", *where, "--json"])  # back to the shipped library
    assert used == {"folder": str(folder.folder), "in_use": 1, "was": 2, "calibration_note": None}
    assert folder.in_use_record().id == 1 and folder.in_use_record().by == "command"


def test_bad_requests_are_one_line(folder, capsys):
    assert main(["library", "use", "7", "--folder", str(folder.folder)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "there is no library version 7 (versions 1-2)" in err
    assert main(["library", "list"]) == 2
    assert "say which library folder" in capsys.readouterr().err
    assert main(["library", "move", "--folder", str(folder.folder), "--to", str(folder.folder)]) == 2
    assert "is where the library is already" in capsys.readouterr().err


def test_the_folder_is_where_the_lab_says_and_moves_with_the_settings(folder, tmp_path, capsys):
    settings = tmp_path / "lab" / "settings.json"
    settings.write_text(
        json.dumps({"kind": "wiithrow.settings", "schema": 1, "settings": {"library_folder": "pa10-library"}})
    )
    cal = tmp_path / "elsewhere" / "cal.json"
    assert library_folder("pa10", settings_folder="pa10-library", settings_path=settings) == folder.folder.resolve()
    assert library_folder("pa10", calibration_path=cal, settings_path=settings) == cal.parent.resolve() / "pa10-library"
    simulated = library_folder("pa10", world="mujoco")
    assert simulated.parent == tmp_path.parent / simulated.parent.name and simulated.name == "pa10-mujoco"
    assert library_folder("pa10", world="kinematic") != simulated  # each world its own
    listed = _json(capsys, ["library", "list", "--settings", str(settings), "--json"])
    assert listed["folder"] == str(folder.folder.resolve()) and listed["in_use"] == 2
    moved = _json(
        capsys, ["library", "move", "--settings", str(settings), "--to", str(tmp_path / "nas" / "lib"), "--json"]
    )
    assert moved["versions"] == 2 and not folder.folder.exists()
    assert json.loads(settings.read_text())["settings"]["library_folder"] == str(tmp_path / "nas" / "lib")
    again = _json(capsys, ["library", "list", "--settings", str(settings), "--json"])
    assert again["in_use"] == 2 and [v["id"] for v in again["versions"]] == [1, 2]


def test_the_old_cache_file_is_read_once_and_never_written(tmp_path, capsys, monkeypatch):
    cache = tmp_path / "cache"
    cache.mkdir()
    monkeypatch.setenv("WIITHROW_CACHE_DIR", str(cache))
    monkeypatch.setenv(SIM_LIBRARIES_ENV, str(tmp_path / "sims"))
    old = cache / OLD_CACHE_NAME.format(arm="pa10")
    shutil.copyfile(default_library_path(), old)
    before = old.read_bytes()
    assert main(["library", "list", "--sim", "--world", "kinematic", "--json"]) == 0
    said = capsys.readouterr()
    listed, err = loads_strict(said.out), said.err
    assert err.count("\n") == 1 and f"a library trained before versions, {old}, is kept as version 1" in err
    assert listed["in_use"] is None and [v["made"]["how"] for v in listed["versions"]] == ["migration"]
    assert main(["library", "list", "--sim", "--world", "kinematic", "--json"]) == 0
    said = capsys.readouterr()
    assert len(loads_strict(said.out)["versions"]) == 1 and said.err == ""  # read once
    assert old.read_bytes() == before


def test_train_keeps_a_worse_library_out_of_use_with_use_if_better(tmp_path, capsys):
    folder = tmp_path / "lib"
    argv = ["train", "--sim", "--world", "kinematic", "--throws", "6", "--out", str(tmp_path / "x.json")]
    result = _json(capsys, [*argv, "--library-folder", str(folder), "--use-if-better", "--json"])
    assert result["version"] == 1 and result["in_use"] is False and result["comparison"]["better"] is False
    assert any("fewer than its area needs" in r for r in result["comparison"]["reasons"])
    store = LibraryStore(folder)
    assert store.in_use_record() is None and store.info(1).how == "training" and store.info(1).throws == 6
    result = _json(capsys, [*argv, "--force", "--library-folder", str(folder), "--use", "--json"])
    assert result["version"] == 2 and result["in_use"] is True and store.in_use_record().id == 2


def test_a_replaced_calibration_is_kept_and_compared(tmp_path, capsys):
    cams = stereo_rig()
    out = tmp_path / "cal.json"
    for seed in (0, 1):
        rng = np.random.default_rng(seed)
        X = points_in_common_view(cams, 30, rng)
        points = tmp_path / f"points{seed}.csv"
        write_calibration_points(points, X, observe_all(cams, X, rng))
        assert main(["calibrate", "--points", str(points), "--out", str(out)]) == 0
    err = capsys.readouterr().err
    kept = list((tmp_path / "cal.versions").iterdir())
    assert len(kept) == 1 and "leave-one-out 3D error (mm)" in err and str(kept[0]) in err
    assert "replaced" in err and "fingerprint" in err
