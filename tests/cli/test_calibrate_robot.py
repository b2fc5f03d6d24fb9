"""`wiithrow calibrate --robot`: the simulated run prints its table and writes the calibration;
without --sim it says there is no arm driver."""

from tests.helpers.strict_json import loads_strict
from wiithrow.app.cli.main import main
from wiithrow.vision import StereoCalibration

#: Poses of the quick calibration: with 8, leaving out the one pose far from the others cost up to
#: 3.0 mm of held-out error once the rig sat 15 cm further back (seeds 0-5: 0.6-3.0 mm; 0.6-1.4 mm
#: before); with 10 it is 0.6-1.0 mm.
POSES = 10


def test_sim_robot_calibration_prints_json_and_writes_the_file(tmp_path, capsys):
    out = tmp_path / "cal.json"
    assert (
        main(
            [
                "calibrate",
                "--robot",
                "--sim",
                "--world",
                "kinematic",
                "--points",
                str(POSES),
                "--out",
                str(out),
                "--json",
                "--seed",
                "2",
            ]
        )
        == 0
    )
    report = loads_strict(capsys.readouterr().out)
    assert report["poses"] == POSES and report["arm"] == "pa10" and report["design"] == "optimal"
    assert [c["points"] for c in report["cameras"]] == [POSES, POSES]
    assert report["loo_error_m"] < 2e-3 and report["against_true_cameras"]["ratio"] < 1.2
    assert StereoCalibration.load(out).meta["poses"] == POSES


def test_sim_robot_calibration_table(tmp_path, capsys):
    out, dlt = tmp_path / "cal.json", tmp_path / "dlt.csv"
    assert (
        main(
            [
                "calibrate",
                "--robot",
                "--sim",
                "--world",
                "kinematic",
                "--points",
                "7",
                "--out",
                str(out),
                "--dlt-csv",
                str(dlt),
            ]
        )
        == 0
    )
    text = capsys.readouterr().out
    for expected in ("cam0", "cam1", "leave-one-out 3D error", "worst poses", "true simulated cameras", "wrote"):
        assert expected in text
    assert dlt.exists()


def test_without_sim_or_with_too_few_poses_one_clear_line(tmp_path, capsys):
    assert main(["calibrate", "--robot", "--points", "30", "--out", str(tmp_path / "c.json")]) == 2
    err = capsys.readouterr().err
    assert "--settings S.json" in err and "--sim" in err and "Traceback" not in err
    assert main(["calibrate", "--robot", "--sim", "--world", "kinematic", "--points", "4"]) == 2
    assert "at least 6 poses" in capsys.readouterr().err
    assert main(["calibrate", "--robot", "--sim", "--world", "kinematic", "--points", "many"]) == 2
    assert "number of poses" in capsys.readouterr().err


def test_six_poses_say_leave_one_out_needs_seven_and_store_null(tmp_path, capsys):
    """6 poses printed a NaN leave-one-out with exit 0, --json a bare NaN, and the file stored NaN."""
    out = tmp_path / "cal.json"
    assert (
        main(["calibrate", "--robot", "--sim", "--world", "kinematic", "--points", "6", "--out", str(out), "--json"])
        == 0
    )
    report = loads_strict(capsys.readouterr().out)
    assert report["loo_error_m"] is None and report["loo_tested"] == 0
    assert "at least 7 points per camera" in report["loo_note"] and report["worst_poses"] == []
    assert loads_strict(out.read_text())["loo_error_m"] is None
    assert main(["calibrate", "--robot", "--sim", "--world", "kinematic", "--points", "6", "--out", str(out)]) == 0
    text = capsys.readouterr().out
    assert "leave-one-out 3D error: not available: leave-one-out needs at least 7 points per camera" in text
    assert "nan" not in text.lower()


def test_no_progress_bar_when_stderr_is_not_a_terminal(tmp_path, capsys):
    assert (
        main(
            [
                "calibrate",
                "--robot",
                "--sim",
                "--world",
                "kinematic",
                "--points",
                "7",
                "--out",
                str(tmp_path / "c.json"),
            ]
        )
        == 0
    )
    err = capsys.readouterr().err
    assert "calibration poses" not in err and "\r" not in err, err
