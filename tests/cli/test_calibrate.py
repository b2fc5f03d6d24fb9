"""`wiithrow calibrate`, `triangulate` and `bench triangulate` as a user runs them."""

import json
import subprocess
import sys

import numpy as np
import pytest

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
    figures = json.loads(capsys.readouterr().out)
    assert {m["method"] for m in figures["methods"]} == {"paper", "normalized", "refined", "robust"}


def test_bench_triangulate_quick_reports_throughput(capsys):
    assert main(["bench", "triangulate", "--quick", "--json"]) == 0
    figures = json.loads(capsys.readouterr().out)
    assert figures["cameras_2"]["points_per_s"] > 0 and figures["cameras_4"]["points_per_s"] > 0
    assert figures["cameras_2"]["mean_error_mm"] < 5.0
    assert "opencv_ratio" in figures
