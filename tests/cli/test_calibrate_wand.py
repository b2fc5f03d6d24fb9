"""`wiithrow calibrate --wand` as a user runs it: simulated remotes, a wand CSV, the frames, and
the result tracking with `wiithrow track`."""

import json

import numpy as np
import pytest

from tests.helpers.wand_rigs import wide_pair
from wiithrow.app.cli.main import main
from wiithrow.vision import StereoCalibration
from wiithrow.vision.wand.wand_csv import read_wand_csv, write_wand_csv
from wiithrow.vision.wand.waver import wave_wand


def strict(text):
    """The one JSON document a --json command prints, refusing NaN."""
    return json.loads(text, parse_constant=lambda name: pytest.fail(f"{name} in the JSON"))


def test_three_simulated_remotes_calibrate_and_then_track(tmp_path, capsys):
    out, record = tmp_path / "wand.json", tmp_path / "wand.csv"
    args = [
        "calibrate",
        "--wand",
        "--sim",
        "--world",
        "kinematic",
        "--cameras",
        "3",
        "--seconds",
        "15",
        "--out",
        str(out),
    ]
    assert main([*args, "--record", str(record), "--json"]) == 0
    report = strict(capsys.readouterr().out)
    assert report["calibration"] == str(out) and report["frame"] == "cam0"
    assert [c["name"] for c in report["cameras"]] == ["cam0", "cam1", "cam2"]
    assert all(0.3 < c["reprojection_rms_px"] < 1.0 and abs(c["focal_px"] - 1300) < 15 for c in report["cameras"])
    assert report["wand_score_percent"] < 1.5 and report["frames"]["held_out"] > 0
    calibration = StereoCalibration.load(out)
    assert len(calibration.cameras) == 3 and calibration.meta["source"] == "wand"
    assert read_wand_csv(record).cameras == 3
    # the wand calibration tracks the simulated rig it was made on
    assert main(["track", "--sim", "--calibration", str(out), "--duration", "0.5"]) == 0
    rows = [json.loads(line) for line in capsys.readouterr().out.splitlines()]
    assert {r["id"] for r in rows} == {0, 1, 2, 3} and {r["frame"] for r in rows} == {"cam0"}


def test_a_wand_csv_calibrates_and_prints_its_quality(tmp_path, capsys):
    rig = wide_pair()
    observations, _ = wave_wand(rig.cameras, 15, np.random.default_rng(80), shuffle=True, depth_m=rig.depth_m)
    path = write_wand_csv(tmp_path / "wand.csv", observations)
    out = tmp_path / "cal.json"
    assert main(["calibrate", "--wand", "--points", str(path), "--wand-length", "0.3", "--out", str(out)]) == 0
    text = capsys.readouterr().out
    assert "wand score" in text and "held-out error" in text and f"wrote {out}" in text
    assert StereoCalibration.load(out).meta["csv"] == str(path)


@pytest.mark.parametrize(
    ("extra", "message"),
    [
        ([], "give the wand's length: --wand-length"),
        (["--wand-length", "0.3", "--frame", "robot"], "--frame robot needs the rig live"),
        (["--wand-length", "0.3", "--frame", "tripod"], "unknown frame 'tripod'"),
        (["--wand-length", "0.3", "--sim"], "two sources of wand dots"),
        (["--wand-length", "300"], "where a Wiimote cannot see it"),
        (["--wand-length", "0.3", "--method", "paper"], "--method does not apply to --wand"),
        (["--wand-length", "0.3", "--seconds", "20"], "--seconds does not apply to --points wand.csv"),
        (["--wand-length", "0.3", "--record", "w.csv"], "--record does not apply to --points wand.csv"),
        (["--wand-length", "0.3", "--out", "/proc/c.json"], "cannot write"),
    ],
)
def test_what_cannot_work_is_one_line_and_exit_2(tmp_path, capsys, extra, message):
    rig = wide_pair()
    observations, _ = wave_wand(rig.cameras, 5, np.random.default_rng(81), depth_m=rig.depth_m)
    path = write_wand_csv(tmp_path / "wand.csv", observations)
    assert main(["calibrate", "--wand", "--points", str(path), "--out", str(tmp_path / "c.json"), *extra]) == 2
    err = capsys.readouterr().err
    assert message in err and err.count("\n") == 1


def test_a_wrong_wand_length_is_caught_by_the_simulated_robot(tmp_path, capsys):
    args = [
        "calibrate",
        "--wand",
        "--sim",
        "--world",
        "kinematic",
        "--seconds",
        "10",
        "--frame",
        "robot",
        "--out",
        str(tmp_path / "c.json"),
    ]
    assert main([*args, "--wand-length", "0.27"]) == 2  # the simulated wand is 0.30 m
    assert "a wand of 0.30" in capsys.readouterr().err
    assert not (tmp_path / "c.json").exists()


def test_wand_options_are_refused_elsewhere(capsys):
    assert main(["calibrate", "--demo", "--wand-length", "0.3"]) == 2
    assert "--wand-length does not apply without --wand" in capsys.readouterr().err
