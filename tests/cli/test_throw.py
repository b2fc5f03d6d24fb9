"""`wiithrow throw` and `wiithrow train` as a user runs them."""

import json

import numpy as np
import pytest

from wiithrow.app.cli.main import main


@pytest.fixture(scope="module")
def calibration(tmp_path_factory):
    """One robot calibration of the simulated rig, through the command line, shared by the tests."""
    path = tmp_path_factory.mktemp("cal") / "calibration.json"
    assert main(["calibrate", "--robot", "--sim", "--out", str(path), "--json"]) == 0
    return str(path)


def test_dry_run_json_is_a_complete_checkable_plan(capsys, calibration):
    assert (
        main(["throw", "--target", "1.2", "0.4", "0.1", "--sim", "--dry-run", "--json", "--calibration", calibration])
        == 0
    )
    plan = json.loads(capsys.readouterr().out)
    assert abs(plan["joint1_rad"] - np.arctan2(0.4, 1.2)) < 0.01
    assert plan["ball_offset_from_flange_m"] == [0.0, 0.0, 0.15]
    traj = plan["trajectory"]
    positions = np.array(traj["positions_rad"])
    assert positions.shape[1] == 7 and abs(traj["dt_s"] - 0.001) < 1e-9
    assert np.allclose(positions[:, 0], plan["joint1_rad"], atol=1e-9)  # joint 1 holds the alignment
    assert plan["release_time_s"] < traj["times_s"][-1]
    assert all(p <= v + 1e-9 for p, v in zip(plan["peak_joint_speed_rad_s"], plan["joint_velocity_limit_rad_s"]))


def test_throw_with_yes_reports_the_error(capsys, calibration):
    assert (
        main(["throw", "--target", "1.3", "-0.2", "0.0", "--sim", "--yes", "--json", "--calibration", calibration]) == 0
    )
    result = json.loads(capsys.readouterr().out)
    assert result["error_m"] < 0.01 and result["true_error_m"] < 0.01


def test_refusals_are_one_clear_line(capsys, calibration):
    assert main(["throw", "--target", "1.3", "0", "0"]) == 2
    assert "arm driver" in capsys.readouterr().err
    assert main(["throw", "--target", "2.4", "0", "0", "--sim", "--dry-run", "--calibration", calibration]) == 2
    err = capsys.readouterr().err
    assert "outside the trained area" in err and "Traceback" not in err
    assert main(["train"]) == 2
    assert "--sim" in capsys.readouterr().err
