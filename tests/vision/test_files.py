"""Atomic versioned files: what a crash, a corrupt file or another version does."""

import json
import os

import pytest

from wiithrow.vision.errors import FileFormatError
from wiithrow.vision.files import atomic_write_text, read_versioned_json, write_versioned_json


def test_round_trip_and_no_temp_files_left(tmp_path):
    path = tmp_path / "sub" / "a.json"
    write_versioned_json(path, "wiithrow.test", 3, {"x": [1, 2]})
    assert read_versioned_json(path, "wiithrow.test", 3)["x"] == [1, 2]
    assert [p.name for p in path.parent.iterdir()] == ["a.json"]


def test_failed_write_keeps_the_old_file(tmp_path, monkeypatch):
    path = tmp_path / "a.json"
    write_versioned_json(path, "wiithrow.test", 1, {"v": "old"})

    def broken_replace(src, dst):
        raise OSError("disk full")

    monkeypatch.setattr(os, "replace", broken_replace)
    with pytest.raises(OSError, match="disk full"):
        write_versioned_json(path, "wiithrow.test", 1, {"v": "new"})
    monkeypatch.undo()
    assert read_versioned_json(path, "wiithrow.test", 1)["v"] == "old"
    assert [p.name for p in tmp_path.iterdir()] == ["a.json"]


@pytest.mark.parametrize(
    "content, message",
    [
        ("{not json", "not valid JSON"),
        ("[1, 2]", "expected a JSON object"),
        (json.dumps({"kind": "other", "schema": 1}), "expected a 'wiithrow.test' file"),
        (json.dumps({"kind": "wiithrow.test", "schema": 99}), "schema version 99"),
    ],
)
def test_bad_files_name_the_file_and_are_left_alone(tmp_path, content, message):
    path = tmp_path / "bad.json"
    atomic_write_text(path, content)
    with pytest.raises(FileFormatError, match=message) as info:
        read_versioned_json(path, "wiithrow.test", 1)
    assert str(path) in str(info.value)
    assert path.read_text() == content


def test_missing_file(tmp_path):
    with pytest.raises(FileFormatError, match="no such file"):
        read_versioned_json(tmp_path / "nope.json", "wiithrow.test", 1)


@pytest.fixture()
def umask():
    """Set the process umask for a test, and restore it afterwards."""
    saved = os.umask(0o022)
    os.umask(saved)

    def set_mask(mask: int) -> None:
        os.umask(mask)

    yield set_mask
    os.umask(saved)


@pytest.mark.parametrize("mask, mode", [(0o022, 0o644), (0o077, 0o600), (0o002, 0o664)])
def test_new_files_respect_the_umask(tmp_path, umask, mask, mode):
    umask(mask)
    path = atomic_write_text(tmp_path / "a.txt", "x")
    assert path.stat().st_mode & 0o777 == mode


def test_overwriting_keeps_the_files_mode(tmp_path, umask):
    umask(0o077)
    path = tmp_path / "a.txt"
    path.write_text("old")
    path.chmod(0o640)
    atomic_write_text(path, "new")
    assert path.read_text() == "new" and path.stat().st_mode & 0o777 == 0o640


def test_versioned_json_is_strict_json_with_null_for_nan(tmp_path):
    path = write_versioned_json(tmp_path / "a.json", "wiithrow.test", 1, {"x": float("nan"), "y": [1.0, float("inf")]})

    def refuse(constant):
        raise ValueError(f"{constant} is not JSON")

    document = json.loads(path.read_text(), parse_constant=refuse)
    assert document["x"] is None and document["y"] == [1.0, None]


def test_json_streamed_to_a_file_is_strict_too(tmp_path):
    from wiithrow.vision.files import dump_strict
    from wiithrow.vision.outputs import OutputFiles

    document = {"ok": list(range(3)), "late": [1.0, float("nan")]}
    path = tmp_path / "a.json"
    OutputFiles().add(path, lambda handle: dump_strict(document, handle, indent=2)).commit()

    def refuse(constant):
        raise ValueError(f"{constant} is not JSON")

    assert json.loads(path.read_text(), parse_constant=refuse) == {"ok": [0, 1, 2], "late": [1.0, None]}


# -- reading JSON from files and messages: nesting and non-finite numbers ---------------------


@pytest.mark.parametrize(
    "text, depth",
    [("1", 0), ('"[[["', 0), ("[]", 1), ("[[1]]", 2), ('{"a": [1, {"b": []}]}', 4), ('["]]]", "\\"[[[[", [[]]]', 3)],
)
def test_json_depth_counts_arrays_and_objects_not_brackets_in_strings(text, depth):
    from wiithrow.vision.files import json_depth

    assert json_depth(text) == depth == json_depth(text.encode())


@pytest.mark.parametrize("depth", [33, 999, 1_000_000])
def test_loads_json_refuses_deep_nesting_in_one_line(depth):
    """33 is one over the limit; 999 parses in Python but breaks recursive code after it; a
    million is Python's own RecursionError: all the same one line."""
    from wiithrow.vision.files import loads_json

    with pytest.raises(FileFormatError) as info:
        loads_json("[" * depth + "]" * depth, "msg")
    assert str(info.value) == (
        "msg: nested deeper than 32 levels (arrays or objects inside each other), which no wiithrow file or message is"
    )


def test_loads_json_reads_the_limit_and_our_documents():
    import numpy as np

    from wiithrow.vision import StereoCalibration
    from wiithrow.vision.dlt import calibrate
    from wiithrow.vision.files import MAX_JSON_DEPTH, json_depth, loads_json
    from wiithrow.vision.rig import observe_all, points_in_common_view, stereo_rig

    assert loads_json("[" * MAX_JSON_DEPTH + "]" * MAX_JSON_DEPTH, "x") == eval(
        "[" * MAX_JSON_DEPTH + "]" * MAX_JSON_DEPTH
    )
    cams, rng = stereo_rig(), np.random.default_rng(0)
    X = points_in_common_view(cams, 20, rng)
    image = observe_all(cams, X, rng)
    text = StereoCalibration(tuple(calibrate(X, image[c], name=f"cam{c}") for c in range(2))).to_text()
    assert json_depth(text) <= 6 and loads_json(text, "cal") == json.loads(text)
    with pytest.raises(FileFormatError, match=r"^x: not valid JSON \(line 1, column 2"):
        loads_json("{", "x")


def test_non_finite_path_says_where():
    from wiithrow.vision.files import non_finite_path

    assert non_finite_path(json.loads('{"a": [1, {"b": [2, NaN]}], "c": 1e999}')) == "a[1].b[1]"
    assert non_finite_path(json.loads('{"c": -1e999}'), "meta") == "meta.c"
    assert non_finite_path({"a": [1, 2.5, None, "NaN"]}) is None
