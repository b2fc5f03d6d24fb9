"""`wiithrow throw` and `wiithrow train` as a user runs them."""

import json
from pathlib import Path

import numpy as np
import pytest

from tests.helpers.strict_json import loads_strict
from wiithrow.app.cli.main import main


@pytest.fixture(scope="module")
def calibration(tmp_path_factory):
    """One robot calibration of the simulated rig, through the command line, shared by the tests."""
    path = tmp_path_factory.mktemp("cal") / "calibration.json"
    assert main(["calibrate", "--robot", "--sim", "--world", "kinematic", "--out", str(path), "--json"]) == 0
    return str(path)


def test_dry_run_json_is_a_complete_checkable_plan(capsys, calibration):
    assert (
        main(
            [
                "throw",
                "--target",
                "1.2",
                "0.4",
                "0.1",
                "--sim",
                "--world",
                "kinematic",
                "--dry-run",
                "--json",
                "--trajectory",
            ]
            + ["--calibration", calibration]
        )
        == 0
    )
    plan = loads_strict(capsys.readouterr().out)
    assert abs(plan["joint1_rad"] - np.arctan2(0.4, 1.2)) < 0.01
    assert plan["ball_offset_from_flange_m"] == [0.0, 0.0, 0.15]
    traj = plan["trajectory"]
    positions = np.array(traj["positions_rad"])
    assert positions.shape[1] == 7 and abs(traj["dt_s"] - 0.001) < 1e-9
    # joint 1 turns from where the alignment left it to the aim (the target's measured azimuth and the
    # learned sideways correction: none in the shipped library) in the prelude, then holds it
    held = np.isclose(positions[:, 0], plan["joint1_rad"], atol=1e-9)
    first = int(np.argmax(held))
    times = np.array(traj["times_s"])
    assert held[first:].all() and times[first] < plan["release_time_s"]
    assert abs(positions[0, 0] - plan["joint1_rad"]) < 0.005 and plan["learned_across_offset_m"] == 0.0
    assert plan["release_time_s"] < traj["times_s"][-1]
    assert all(p <= v + 1e-9 for p, v in zip(plan["peak_joint_speed_rad_s"], plan["joint_velocity_limit_rad_s"]))


def test_throw_with_yes_reports_the_error(capsys, calibration):
    assert (
        main(
            [
                "throw",
                "--target",
                "1.3",
                "-0.2",
                "0.0",
                "--sim",
                "--world",
                "kinematic",
                "--yes",
                "--json",
                "--calibration",
                calibration,
            ]
        )
        == 0
    )
    result = loads_strict(capsys.readouterr().out)["result"]
    assert result["error_m"] < 0.01 and result["true_error_m"] < 0.01
    # the 3D error, along / across / height and the total on the surface, measured and true
    for error, total in ((result["error"], result["error_m"]), (result["true_error"], result["true_error_m"])):
        assert error["total_m"] == total == pytest.approx(np.hypot(error["along_m"], error["across_m"]))
        assert abs(error["height_m"]) < 0.005


def test_the_library_file_is_never_written_and_learning_adds_one_version(capsys, calibration, tmp_path):
    from wiithrow.app.throws.library_file import default_library_path
    from wiithrow.app.throws.library_store import LibraryStore

    library = tmp_path / "library.json"
    library.write_bytes(default_library_path().read_bytes())
    before = library.read_bytes()
    folder = tmp_path / "lab-library"
    argv = ["throw", "--target", "1.3", "0.1", "0.1", "--sim", "--yes", "--json", "--calibration", calibration]
    argv += ["--library-folder", str(folder)]
    assert main([*argv, "--library", str(library), "--no-learn"]) == 0
    said = capsys.readouterr()
    assert loads_strict(said.out)["result"]["learning"] is None
    assert f"{library} kept as library version 1 of {folder}, in use" in said.err
    assert library.read_bytes() == before and LibraryStore(folder).ids() == [1]
    assert main([*argv, "--library", str(library)]) == 0  # the version in use already: not kept again
    learning = loads_strict(capsys.readouterr().out)["result"]["learning"]
    store = LibraryStore(folder)
    assert learning["joined"] == 1 and learning["saved_to"] == str(store.path(2)) and learning["version"] == 2
    assert library.read_bytes() == before and store.ids() == [1, 2] and store.in_use_record().id == 2
    history = json.loads(store.path(2).read_text())["library"]["meta"]["learning"]["history"]
    assert len(history) == 1


def test_refusals_are_one_clear_line(capsys, calibration):
    assert main(["throw", "--target", "1.3", "0", "0"]) == 2
    assert "--settings S.json" in capsys.readouterr().err
    assert (
        main(
            [
                "throw",
                "--target",
                "2.4",
                "0",
                "0",
                "--sim",
                "--world",
                "kinematic",
                "--dry-run",
                "--calibration",
                calibration,
            ]
        )
        == 2
    )
    err = capsys.readouterr().err
    assert "outside the trained area" in err and "Traceback" not in err
    assert main(["train"]) == 2
    assert "--sim" in capsys.readouterr().err


def _one_line(capsys, command, *needles):
    # a run's first line names its world; the error is the one line after it
    err = "\n".join(line for line in capsys.readouterr().err.strip().splitlines() if not line.startswith("world: "))
    assert err.startswith(f"wiithrow {command}: ") and "Traceback" not in err, err
    last = err.splitlines()[-1]
    assert len(err.splitlines()) == 1, err
    for needle in needles:
        assert needle in last, last
    return last


@pytest.fixture()
def no_calibrating(monkeypatch):
    """Fail if the command starts the minute-long robot calibration (inputs are checked first)."""
    from wiithrow.app.session import simulated

    monkeypatch.setattr(
        simulated, "simulated_rig_calibration", lambda *a, **k: pytest.fail("calibrated before checking the inputs")
    )


@pytest.fixture()
def edited(tmp_path):
    def edit(source, change, name):
        document = json.loads(Path(source).read_text())
        change(document)
        path = tmp_path / name
        path.write_text(json.dumps(document))
        return str(path)

    return edit


def test_broken_calibrations_are_one_line_before_anything_moves(capsys, calibration, edited):
    """An all-zero P was a LinAlgError traceback; three cameras "2 drivers for 3 calibrated cameras"."""
    zero = edited(calibration, lambda d: d["cameras"][0].update(P=[[0.0] * 4] * 3), "zero.json")
    three = edited(calibration, lambda d: d["cameras"].append(dict(d["cameras"][1], name="cam2")), "three.json")
    shifted = [[1, 0, 0, 0.3], [0, 1, 0, 0], [0, 0, 1, 1]]
    three = edited(three, lambda d: d["cameras"][2].update(P=shifted), "three.json")
    base = edited(calibration, lambda d: d.update(frame="base"), "base.json")
    argv = ["throw", "--target", "1.3", "0", "0", "--sim", "--world", "kinematic", "--dry-run", "--calibration"]
    assert main([*argv, zero]) == 2
    _one_line(capsys, "throw", "cam0: its projection matrix is degenerate")
    assert main([*argv, three]) == 2
    _one_line(capsys, "throw", "the calibration has 3 cameras and the rig 2 remotes")
    assert main([*argv, base]) == 2
    _one_line(capsys, "throw", "in frame 'base'")


@pytest.mark.parametrize("arm", ["ur5", "nonsense"])
def test_a_library_of_another_arm_is_refused_before_calibrating(capsys, tmp_path, edited, no_calibrating, arm):
    from wiithrow.app.throws.library_file import default_library_path

    library = edited(default_library_path(), lambda d: d.update(arm=arm), f"{arm}.json")
    assert (
        main(["throw", "--target", "1.3", "0", "0", "--sim", "--world", "kinematic", "--dry-run", "--library", library])
        == 2
    )
    _one_line(capsys, "throw", f"trained for arm {arm!r}", "'pa10'")


def test_a_target_far_outside_the_trained_area_is_refused_before_calibrating(capsys, no_calibrating):
    assert main(["throw", "--target", "3.0", "0", "0", "--sim", "--world", "kinematic", "--dry-run"]) == 2
    _one_line(capsys, "throw", "outside the trained area")


@pytest.mark.parametrize("target", [("-1.3", "0", "0.2"), ("-1.2", "-0.05", "0.1")])
def test_a_target_behind_the_arm_is_refused_before_calibrating_saying_why(capsys, no_calibrating, target):
    """Joint 1 (S1) turns -177 to 177 deg: the azimuth of (-1.3, 0) is 180 deg; today's 30-s search ended
    "not aligned within 30.0 s" without a reason."""
    assert main(["throw", "--target", *target, "--sim", "--world", "kinematic", "--dry-run"]) == 2
    _one_line(capsys, "throw", "beyond the range joint 1 (S1) turns, -177 to 177 deg", "behind the arm")


def test_the_trajectory_is_in_the_json_only_when_asked(capsys, calibration):
    argv = [
        "throw",
        "--target",
        "1.2",
        "0.4",
        "0.1",
        "--sim",
        "--world",
        "kinematic",
        "--dry-run",
        "--json",
        "--calibration",
        calibration,
    ]
    assert main(argv) == 0
    plan = capsys.readouterr().out
    assert "trajectory" not in loads_strict(plan) and len(plan) < 4_000, len(plan)
    assert main([*argv, "--trajectory"]) == 0
    assert len(loads_strict(capsys.readouterr().out)["trajectory"]["positions_rad"]) > 1000


@pytest.mark.parametrize(
    "extra, needle",
    [
        (["--yes", "--dry-run"], "--yes does not apply"),
        (["--recalibrate", "--calibration", "c.json"], "--recalibrate"),
        (["--trajectory"], "--trajectory does not apply without --json"),
    ],
)
def test_flags_that_do_not_apply(capsys, no_calibrating, extra, needle):
    assert main(["throw", "--target", "1.3", "0", "0", "--sim", "--world", "kinematic", *extra]) == 2
    _one_line(capsys, "throw", needle)


def test_one_json_schema_with_frames_in_the_keys(capsys, calibration):
    argv = [
        "throw",
        "--target",
        "1.3",
        "-0.2",
        "0.0",
        "--sim",
        "--world",
        "kinematic",
        "--json",
        "--calibration",
        calibration,
    ]
    assert main([*argv, "--dry-run"]) == 0
    plan = loads_strict(capsys.readouterr().out)
    assert main([*argv, "--yes"]) == 0
    thrown = loads_strict(capsys.readouterr().out)
    assert set(plan) == set(thrown) and plan["result"] is None and plan["thrown"] is False
    assert thrown["thrown"] is True and set(thrown["result"]) >= {"error_m", "landing_measured_throw_plane_link1_m"}
    assert plan["target_base_m"] == [1.3, -0.2, 0.0]
    for document in (plan, thrown, thrown["result"]):
        for key, value in document.items():
            if key.endswith("_m") and isinstance(value, dict | list) and key != "trajectory":
                assert any(f in key for f in ("_base_", "_link1_", "_flange_")), key
            if isinstance(value, dict) and key.endswith("_link1_m"):
                assert set(value) == {"x", "z"}, key
