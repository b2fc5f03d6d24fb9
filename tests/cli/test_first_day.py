"""A newcomer's first day through the real commands (issue 45): `train` and `throw` measure with the
calibration `wiithrow calibrate` just wrote in the current folder and say so, or say why they do
not; `throw` names its library and calibration; the MuJoCo rehearsal's world line says its devices
are simulated; `track` says how long it tracks; an unknown flag or command gets the closest one."""

from __future__ import annotations

import json
import os
import shutil
from pathlib import Path

import pytest

from tests.helpers.strict_json import loads_strict
from wiithrow.app.cli.calibration_choice import choose_calibration
from wiithrow.app.cli.main import main
from wiithrow.vision import StereoCalibration

REPO = Path(__file__).resolve().parents[2]
REHEARSAL = REPO / "examples" / "mujoco_settings.json"
#: A dry run at a target inside the shipped library's trained area, in the fast world.
DRY_RUN = ["throw", "--target", "1.3", "0", "0", "--sim", "--world", "kinematic", "--dry-run", "--json", "--seed", "0"]


@pytest.fixture(scope="module")
def made(tmp_path_factory) -> Path:
    """What `wiithrow calibrate --robot --sim` writes: the fewest poses a calibration takes (6), seeded."""
    path = tmp_path_factory.mktemp("calibrate") / "cal.json"
    argv = ["calibrate", "--robot", "--sim", "--world", "kinematic", "--points", "6", "--seed", "0"]
    assert main([*argv, "--out", str(path), "--json"]) == 0
    return path


@pytest.fixture()
def lab(tmp_path, monkeypatch, made) -> Path:
    """The current folder, holding `wiithrow calibrate`'s cal.json."""
    shutil.copy(made, tmp_path / "cal.json")
    monkeypatch.chdir(tmp_path)
    return tmp_path


def edited(folder: Path, name: str, change, age_s: float = 0.0) -> Path:
    """A copy of cal.json as `name`, changed by `change(document)`, written `age_s` later than cal.json."""
    document = json.loads((folder / "cal.json").read_text())
    change(document)
    path = folder / name
    path.write_text(json.dumps(document))
    stamp = (folder / "cal.json").stat().st_mtime + age_s
    os.utime(path, (stamp, stamp))
    return path


def never_calibrate(monkeypatch):
    from wiithrow.app.session import simulated

    monkeypatch.setattr(simulated, "simulated_rig_calibration", lambda *a, **k: pytest.fail("calibrated the sim rig"))


def test_throw_uses_the_calibration_calibrate_wrote_and_names_it_and_its_library(capsys, lab, monkeypatch):
    never_calibrate(monkeypatch)
    assert main(DRY_RUN) == 0
    captured = capsys.readouterr()
    plan = loads_strict(captured.out)
    fingerprint = StereoCalibration.load(lab / "cal.json").fingerprint
    assert plan["calibration"] == {"file": "cal.json", "chosen": "newest", "fingerprint": fingerprint}
    assert plan["library"]["source"] == "shipped" and plan["library"]["version"] is None
    assert Path(plan["library"]["file"]).is_file()
    lines = captured.err.splitlines()
    assert lines[0].startswith("world: kinematic")
    assert lines[1] == (
        "wiithrow throw: calibration: cal.json (the newest calibration in this folder for arm pa10 in the kinematic "
        "world; --calibration to choose another, --recalibrate to make a new one)"
    )
    assert lines[2].startswith(f"wiithrow throw: library: the shipped library, {plan['library']['file']} (no version")


def test_train_uses_it_too(capsys, lab, monkeypatch):
    from wiithrow.app.cli.commands import train

    never_calibrate(monkeypatch)
    measured_with: list[str | None] = []

    def stop_before_the_throws(args, session, out):
        measured_with.append(session.calibration_fingerprint())
        return 0

    monkeypatch.setattr(train, "_train", stop_before_the_throws)
    assert main(["train", "--sim", "--world", "kinematic", "--throws", "5", "--out", "lib.json"]) == 0
    assert measured_with == [StereoCalibration.load(lab / "cal.json").fingerprint]
    assert "wiithrow train: calibration: cal.json (the newest calibration in this folder for arm pa10" in (
        capsys.readouterr().err
    )


def test_the_newest_fitting_one_is_used_and_a_newer_one_that_does_not_fit_is_said(capsys, lab, monkeypatch):
    never_calibrate(monkeypatch)
    edited(lab, "older.json", lambda d: None, age_s=-60)
    edited(lab, "mujoco.json", lambda d: d["meta"].update(world="mujoco"), age_s=60)
    edited(lab, "panda.json", lambda d: d.update(arm="panda"), age_s=30)
    assert main(DRY_RUN) == 0
    captured = capsys.readouterr()
    assert loads_strict(captured.out)["calibration"]["file"] == "cal.json"
    said = [line for line in captured.err.splitlines() if "calibration: not using" in line]
    assert said == [
        "wiithrow throw: calibration: not using mujoco.json (newer): made in the MuJoCo world, not in the kinematic world",
        "wiithrow throw: calibration: not using panda.json (newer): made on arm panda, not pa10",
    ]


def test_a_calibration_for_another_world_is_said_and_the_sim_rig_calibrates_as_before(capsys, lab, monkeypatch):
    from wiithrow.app.session import simulated
    from wiithrow.app.worlds import SimWorld

    edited(lab, "cal.json", lambda d: d["meta"].update(world="mujoco"))
    (lab / "notes.json").write_text('{"kind": "notes"}')  # not a calibration: not named
    calls = []

    def true_cameras(settings, **kwargs):
        calls.append(kwargs)
        return SimWorld(settings, seed=0).true_calibration()

    monkeypatch.setattr(simulated, "simulated_rig_calibration", true_cameras)
    assert main(DRY_RUN) == 0
    captured = capsys.readouterr()
    assert len(calls) == 1  # the simulated rig's own, as without a file
    assert loads_strict(captured.out)["calibration"]["chosen"] == "simulated"
    lines = captured.err.splitlines()
    assert lines[1:3] == [
        "wiithrow throw: calibration: not using cal.json: made in the MuJoCo world, not in the kinematic world",
        "wiithrow throw: calibration: the simulated rig's robot calibration (no calibration file in this folder for "
        "arm pa10 in the kinematic world; --calibration to choose one, --recalibrate to make a new one)",
    ]


def test_the_hardware_path_takes_a_hardware_calibration_made_with_its_settings(lab):
    """`calibrate --robot --settings S.json` records the settings it ran with; only such a calibration
    (or one that names no settings) is the hardware path's, never a simulated world's."""
    settings = str(REHEARSAL)

    def choose():
        return choose_calibration(
            given=None, recalibrate=False, arm="pa10", remotes=2, world=None, settings_path=settings
        )

    nothing = choose()
    assert nothing.calibration is None and nothing.skipped == (
        ("cal.json", "made in the simulated kinematic world, not on the hardware path"),
    )
    with pytest.raises(Exception, match=r"pass --calibration cal.json .*\(cal.json: made in the simulated kinematic"):
        from wiithrow.app.cli.calibration_choice import required_on_hardware

        required_on_hardware(nothing, "throwing", "pa10")
    edited(lab, "other.json", lambda d: d["meta"].update(simulated=False, settings="elsewhere.json"), age_s=10)
    edited(lab, "lab.json", lambda d: d["meta"].update(simulated=False, settings=settings), age_s=5)
    chosen = choose()
    assert chosen.how == "newest" and chosen.path == "lab.json"
    assert chosen.lines[0] == (
        "calibration: not using other.json (newer): made with settings elsewhere.json, not " + settings
    )
    assert chosen.lines[-1].startswith(
        f"calibration: lab.json (the newest calibration in this folder for arm pa10 in "
        f"the hardware path with settings {settings}; --calibration to choose another"
    )


def test_given_and_recalibrate_are_used_as_asked(lab):
    given = choose_calibration(given="cal.json", recalibrate=False, arm="pa10", remotes=2, world="mujoco")
    assert given.how == "given" and given.lines == ("calibration: cal.json (--calibration)",)
    again = choose_calibration(given=None, recalibrate=True, arm="pa10", remotes=2, world="kinematic")
    assert again.how == "recalibrate" and again.calibration is None


def test_the_rehearsal_says_its_devices_are_mujocos():
    from wiithrow.app.cli.world_choice import hardware_world_line
    from wiithrow.app.settings import Settings

    line = hardware_world_line(Settings.load(REHEARSAL), "S.json")
    assert line.startswith(
        "world: hardware path on MuJoCo's simulated arm, gripper and remotes, not real devices (settings S.json: arm pa10"
    )
    real = hardware_world_line(Settings(arm_driver="lab.arm:make"), "S.json")
    assert (
        real.startswith("world: hardware (settings S.json: arm pa10, arm_driver lab.arm:make") and "MuJoCo" not in real
    )


@pytest.mark.parametrize("realtime", [False, True])
def test_track_says_how_long_it_tracks(capsys, realtime):
    argv = ["track", "--sim", "--duration", "0.05", "--seed", "0"] + (["--realtime"] if realtime else [])
    assert main(argv) == 0
    lines = capsys.readouterr().err.splitlines()
    clock = "" if realtime else " of simulated time, faster than real time unless --realtime"
    assert lines[1] == f"wiithrow track: tracking for 0.05 s{clock} (--duration to change; Ctrl-C stops early)"


@pytest.mark.parametrize(
    "argv, line",
    [
        (["throw", "--calibraton", "x"], "wiithrow throw: unknown flag --calibraton (did you mean --calibration?)"),
        (
            ["train", "--sim", "--recalbirate"],
            "wiithrow train: unknown flag --recalbirate (did you mean --recalibrate?)",
        ),
        (["track", "--duraton=3"], "wiithrow track: unknown flag --duraton (did you mean --duration?)"),
        (
            ["library", "use", "3", "--foldr", "x"],
            "wiithrow library use: unknown flag --foldr (did you mean --folder?)",
        ),
        (["throw", "--zzzzzz"], "wiithrow throw: unknown flag --zzzzzz (see `wiithrow throw --help`)"),
        (["throw", "--sim", "stray"], "wiithrow throw: unrecognized arguments: stray (see `wiithrow throw --help`)"),
        (["thorw", "--sim"], "wiithrow: unknown command 'thorw' (did you mean throw?)"),
        (["calbirate"], "wiithrow: unknown command 'calbirate' (did you mean calibrate?)"),
    ],
)
def test_an_unknown_flag_or_command_is_one_line_with_the_closest(capsys, argv, line):
    assert main(argv) == 2
    assert capsys.readouterr().err.splitlines() == [line]
