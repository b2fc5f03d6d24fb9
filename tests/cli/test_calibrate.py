"""`wiithrow calibrate`, `triangulate` and `bench triangulate` as a user runs them."""

import os
import subprocess
import sys

import numpy as np
import pytest

from tests.helpers.strict_json import loads_strict
from wiithrow.app.calibration.point_files import write_calibration_points
from wiithrow.app.cli.main import main
from wiithrow.vision import StereoCalibration, load_dlt_coefficients
from wiithrow.vision.rig import observe_all, points_in_common_view, stereo_rig


@pytest.fixture()
def points_csv(tmp_path):
    cams = stereo_rig()
    rng = np.random.default_rng(0)
    X = points_in_common_view(cams, 30, rng)
    image = observe_all(cams, X, rng)
    image[1, 4] = np.nan  # camera 1 missed one point
    path = tmp_path / "points.csv"
    write_calibration_points(path, X, image)
    return path, cams, X


def test_calibrate_from_csv_writes_json_and_dlt_csv(points_csv, tmp_path, capsys):
    path, _cams, _ = points_csv
    out, dlt = tmp_path / "cal.json", tmp_path / "dlt.csv"
    assert main(["calibrate", "--points", str(path), "--out", str(out), "--dlt-csv", str(dlt)]) == 0
    text = capsys.readouterr().out
    assert "cam0" in text and "leave-one-out 3D error" in text
    calibration = StereoCalibration.load(out)
    assert [c.world.shape[0] for c in calibration.cameras] == [30, 29]
    assert calibration.loo_error_m < 0.006
    assert load_dlt_coefficients(dlt).shape == (2, 3, 4)


def test_triangulate_command_reproduces_the_points(points_csv, tmp_path):
    path, cams, _ = points_csv
    cal = tmp_path / "cal.json"
    main(["calibrate", "--points", str(path), "--out", str(cal)])
    rng = np.random.default_rng(5)
    T = points_in_common_view(cams, 100, rng)
    pixels = observe_all(cams, T, rng).transpose(1, 0, 2).reshape(100, 4)
    src = tmp_path / "pixels.csv"
    np.savetxt(src, pixels, delimiter=",", header="u0,v0,u1,v1", comments="")
    dst = tmp_path / "xyz.csv"
    assert main(["triangulate", "--calibration", str(cal), "--points", str(src), "--out", str(dst)]) == 0
    xyz = np.genfromtxt(dst, delimiter=",", skip_header=1)[:, :3]
    assert np.mean(np.linalg.norm(xyz - T, axis=1)) < 0.005


def test_bad_input_gives_one_line_and_exit_2(tmp_path, capsys):
    bad = tmp_path / "few.csv"
    bad.write_text("x,y,z,u0,v0,u1,v1\n" + "0.5,0,0.3,500,380,510,380\n" * 3)
    assert main(["calibrate", "--points", str(bad), "--out", str(tmp_path / "c.json")]) == 2
    err = capsys.readouterr().err
    assert "calibrate:" in err and "Traceback" not in err
    assert not (tmp_path / "c.json").exists()
    assert main(["triangulate", "--calibration", str(tmp_path / "none.json"), "--points", str(bad)]) == 2
    assert "no such file" in capsys.readouterr().err


def test_console_script_help_lists_the_commands():
    out = subprocess.run(
        [sys.executable, "-m", "wiithrow.app.cli.main", "--help"], capture_output=True, text=True, check=True
    ).stdout
    for command in ("demo", "calibrate", "triangulate", "bench"):
        assert command in out


def test_calibrate_demo_prints_the_comparison(capsys):
    assert main(["calibrate", "--demo", "--json"]) == 0
    figures = loads_strict(capsys.readouterr().out)
    assert {m["method"] for m in figures["methods"]} == {"paper", "normalized", "refined", "robust"}


def test_bench_triangulate_quick_reports_throughput(capsys):
    assert main(["bench", "triangulate", "--quick", "--json"]) == 0
    figures = loads_strict(capsys.readouterr().out)
    assert figures["cameras_2"]["points_per_s"] > 0 and figures["cameras_4"]["points_per_s"] > 0
    assert figures["cameras_2"]["mean_error_mm"] < 5.0
    assert "opencv_ratio" in figures


def _no_fit(monkeypatch):
    """Fail the test if the command starts fitting (outputs must be checked before the work)."""
    from wiithrow.app.cli.commands import calibrate

    monkeypatch.setattr(calibrate, "calibrate_rig", lambda *a, **k: pytest.fail("fitted before checking the outputs"))


def _one_line(capsys, *needles):
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "Traceback" not in err, err
    assert err.startswith("wiithrow calibrate: "), err
    for needle in needles:
        assert needle in err, err
    return err


@pytest.mark.parametrize(
    "target, needle",
    [
        (lambda d: d / "afile" / "cal.json", "is a file, not a folder"),
        (lambda d: d / "adir", "it is a folder"),
        (lambda d: "/sys/cal.json", "not writable"),
    ],
)
@pytest.mark.parametrize("flag", ["--out", "--dlt-csv"])
def test_unwritable_outputs_are_refused_before_the_work_and_nothing_is_written(
    points_csv, tmp_path, capsys, monkeypatch, target, needle, flag
):
    path, _, _ = points_csv
    (tmp_path / "afile").write_text("x")
    (tmp_path / "adir").mkdir()
    before = sorted(p.name for p in tmp_path.iterdir())
    _no_fit(monkeypatch)
    other = ["--dlt-csv", str(tmp_path / "dlt.csv")] if flag == "--out" else ["--out", str(tmp_path / "cal.json")]
    assert main(["calibrate", "--points", str(path), flag, str(target(tmp_path)), *other]) == 2
    _one_line(capsys, needle)
    assert sorted(p.name for p in tmp_path.iterdir()) == before


def test_the_default_output_is_not_replaced_without_force(points_csv, tmp_path, capsys, monkeypatch):
    path, _, _ = points_csv
    monkeypatch.chdir(tmp_path)
    (tmp_path / "calibration.json").write_text("a robot calibration that took an afternoon")
    assert main(["calibrate", "--points", str(path)]) == 2
    _one_line(capsys, "calibration.json exists", "--force")
    assert (tmp_path / "calibration.json").read_text().startswith("a robot calibration")
    assert main(["calibrate", "--points", str(path), "--force"]) == 0
    assert StereoCalibration.load(tmp_path / "calibration.json").loo_error_m < 0.006
    assert main(["calibrate", "--points", str(path), "--out", "calibration.json"]) == 0  # named: replaced


def test_written_files_follow_the_umask_and_keep_their_mode(points_csv, tmp_path):
    path, _, _ = points_csv
    saved = os.umask(0o022)
    try:
        out, dlt = tmp_path / "cal.json", tmp_path / "dlt.csv"
        assert main(["calibrate", "--points", str(path), "--out", str(out), "--dlt-csv", str(dlt)]) == 0
        assert out.stat().st_mode & 0o777 == 0o644 and dlt.stat().st_mode & 0o777 == 0o644
        out.chmod(0o640)
        assert main(["calibrate", "--points", str(path), "--out", str(out)]) == 0
        assert out.stat().st_mode & 0o777 == 0o640
    finally:
        os.umask(saved)


@pytest.mark.parametrize(
    "extra, needle",
    [
        (["--sim"], "--sim does not apply to --points FILE.csv"),
        (["--seed", "3"], "--seed does not apply to --points FILE.csv"),
    ],
)
def test_flags_that_do_not_apply_are_refused(points_csv, tmp_path, capsys, monkeypatch, extra, needle):
    path, _, _ = points_csv
    monkeypatch.chdir(tmp_path)
    assert main(["calibrate", "--points", str(path), *extra]) == 2
    _one_line(capsys, needle)
    assert [p.name for p in tmp_path.iterdir()] == ["points.csv"]


@pytest.mark.parametrize(
    "argv, needle",
    [
        (["--demo", "--points", "x.csv"], "--points does not apply to --demo"),
        (["--demo", "--out", "x.json"], "--out does not apply to --demo"),
        (["--robot", "--sim", "--frame", "base"], "--frame does not apply to --robot"),
        (["--robot", "--sim", "--out", "a.json", "--dlt-csv", "a.json"], "name the same file"),
    ],
)
def test_mode_flags_that_do_not_apply_are_refused(tmp_path, capsys, monkeypatch, argv, needle):
    monkeypatch.chdir(tmp_path)
    assert main(["calibrate", *argv]) == 2
    _one_line(capsys, needle)
    assert list(tmp_path.iterdir()) == []


def test_points_are_numbered_from_one_as_in_the_file(tmp_path, capsys):
    cams = stereo_rig()
    rng = np.random.default_rng(0)
    X = points_in_common_view(cams, 30, rng)
    image = observe_all(cams, X, rng)
    image[0, 5] += 25.0  # the 6th data row is badly measured
    path = tmp_path / "points.csv"
    write_calibration_points(path, X, image)
    assert main(["calibrate", "--points", str(path), "--out", str(tmp_path / "c.json"), "--json"]) == 0
    report = loads_strict(capsys.readouterr().out)
    assert report["worst_points"][0]["point"] == 6
    assert main(["calibrate", "--points", str(path), "--out", str(tmp_path / "c.json")]) == 0
    assert "worst points (numbered from 1): #6 " in capsys.readouterr().out
    duplicated = tmp_path / "dup.csv"
    write_calibration_points(duplicated, np.vstack([X, X[3:4]]), np.concatenate([image, image[:, 3:4]], axis=1))
    assert main(["calibrate", "--points", str(duplicated), "--out", str(tmp_path / "d.json")]) == 2
    _one_line(capsys, "points 4 (numbered from 1) occur more than once")


@pytest.mark.parametrize("target, needle", [(lambda d: d / "afile" / "xyz.csv", "is a file"), (lambda d: d, "folder")])
def test_triangulate_refuses_an_unwritable_out_before_reading(tmp_path, capsys, target, needle):
    (tmp_path / "afile").write_text("x")
    argv = ["triangulate", "--calibration", str(tmp_path / "none.json"), "--points", "none.csv"]
    assert main([*argv, "--out", str(target(tmp_path))]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("wiithrow triangulate: cannot write") and needle in err and len(err.splitlines()) == 1
