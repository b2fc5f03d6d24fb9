"""Every command on the hardware path (issue 22, item 1): `calibrate --robot --settings`, `train
--settings` and `throw --settings` over the MuJoCo drivers (`examples/mujoco_settings.json`: the
rehearsal, the same code a lab's drivers run), each in a subprocess on the system clock, as a lab
runs them. Nothing here reads the simulation's truth: the calibration is the robot's, the library's
labels are the rig's measurements of the marker the drivers' simulated operator puts down when the
command asks (this test is the operator who presses Enter, after the ball came down), and each throw
is scored by the rig (the measured landing against the measured target)."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import threading
import time
from pathlib import Path

import numpy as np
import pytest

from tests.helpers.strict_json import loads_strict
from wiithrow.app.cli.main import main

SETTINGS = Path(__file__).resolve().parents[2] / "examples" / "mujoco_settings.json"
WIITHROW = str(Path(sys.executable).with_name("wiithrow"))

#: Small enough for a test, as the task allows: 16 poses (the arm's kinematics are then taken as
#: nominal: identifying them needs 20), 10 training throws (a 5 x 2 grid over the training area).
POSES = 16
THROWS = 10

#: Targets (base, m) the lab puts down, inside the trained area (distance 1.0-1.6 m, height 0-0.4 m),
#: at azimuths on both sides; the MuJoCo drivers' lab puts its target at `mujoco.target_base`.
TARGETS = [(1.274, 0.258, 0.2), (1.15, -0.15, 0.1), (1.45, 0.2, 0.3)]

#: The rig-measured error bound: the median of the throws within the cup of issue 22 (50 mm). A
#: 10-throw library on a 5 x 2 grid (heights 0 and 0.4 m only) generalises worse than the paper's
#: 25 (its regression's own held-out error, measured here: 24 mm median, 96 mm max at the grid's
#: corners), and the robot calibration of 16 poses has ~6 px RMS in MuJoCo: 14-22 mm measured at
#: these targets (load average ~8 on 2 cores). These commands run on the system clock, as on
#: hardware; the MuJoCo hand opens at the release time on its own clock (`open_at`), so a loaded
#: host no longer throws late (bench throwing --settings: median 72 mm with the host opening the
#: hand, 3.5 mm with the scheduled open), but the bound stays the median's, not every throw's (the
#: alignment on a starved rig can still fail); a library that did not learn the world, or landings
#: not measured, miss more.
MEDIAN_M = 0.05
#: Each training label (the rig's measurement of the marker) lies near its training target: their
#: median distance (measured 3-17 mm, one late throw 54 mm).
LABEL_MEDIAN_M = 0.03

pytestmark = pytest.mark.slow


def run_as_operator(argv: list[str], env: dict[str, str], timeout_s: float = 600.0) -> tuple[int, str, str]:
    """Run `wiithrow argv` and be its operator: at each "press Enter" prompt wait for the ball to come
    down and the simulated operator to put the marker there (2 s on the system clock), then press
    Enter. Returns the exit status, stdout and stderr."""
    child = subprocess.Popen(
        [WIITHROW, *argv], stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env
    )
    assert child.stdin is not None and child.stdout is not None and child.stderr is not None
    out: list[str] = []
    reader = threading.Thread(target=lambda: out.append(child.stdout.read()), daemon=True)  # type: ignore[union-attr]
    reader.start()
    err: list[str] = []
    timer = threading.Timer(timeout_s, child.kill)
    timer.start()
    try:
        for line in child.stderr:
            err.append(line)
            if "press Enter" in line:
                time.sleep(2.0)
                child.stdin.write("\n")
                child.stdin.flush()
        child.wait()
    finally:
        timer.cancel()
    reader.join(timeout=10)
    return child.returncode, "".join(out), "".join(err)


@pytest.fixture(scope="module")
def lab(tmp_path_factory):
    """A lab's files: the cache (driver reports, none here) and a settings file per target."""
    root = tmp_path_factory.mktemp("hardware_path")
    env = {**os.environ, "WIITHROW_CACHE_DIR": str(root / "cache")}
    document = json.loads(SETTINGS.read_text())
    settings = []
    for k, target in enumerate(TARGETS):
        path = root / f"settings{k + 1}.json"
        document["settings"]["mujoco"] = {"target_base": list(target)}
        path.write_text(json.dumps(document))
        settings.append(path)
    return root, env, settings


def test_calibrate_train_and_throw_through_the_settings_drivers(lab):
    root, env, settings = lab
    calibration, library = root / "cal.json", root / "lib.json"

    code, out, err = run_as_operator(
        [
            "calibrate",
            "--robot",
            "--settings",
            str(SETTINGS),
            "--points",
            str(POSES),
            "--out",
            str(calibration),
            "--json",
        ],
        env,
    )
    assert code == 0, err
    assert err.splitlines()[0].startswith(
        f"world: hardware path on MuJoCo's simulated arm, gripper and remotes, not real devices (settings {SETTINGS}: "
        "arm pa10, arm_driver "
    )
    report = loads_strict(out)
    assert report["world"] == "hardware" and report["poses"] == POSES and calibration.is_file()
    assert report["loo_error_m"] < 0.02, report["loo_error_m"]  # the LED's 3D position, held out, within 2 cm

    code, out, err = run_as_operator(
        [
            "train", "--settings", str(SETTINGS), "--calibration", str(calibration),
            "--throws", str(THROWS), "--out", str(library), "--json",
        ],
        env,
    )  # fmt: skip
    assert code == 0, err
    assert "has no passing driver report" in err  # warned: nobody ran check-driver here
    # every label is the operator's marker, measured: one prompt per throw, and one more each time the
    # rig saw no marker yet (the command asks again, as an operator looks again)
    assert err.count("press Enter") - err.count("the rig does not see a marker") == THROWS, err
    trained = loads_strict(out)
    assert trained["world"] == "hardware" and trained["throws"] == THROWS and trained["arm"] == "pa10"
    throws = json.loads(library.read_text())["throws"]
    labels, targets = np.array([t["landing"] for t in throws]), np.array([t["target"] for t in throws])
    # each label is the rig's measurement of where the ball came down, near the training target
    assert np.median(np.linalg.norm(labels - targets, axis=1)) < LABEL_MEDIAN_M, labels - targets

    errors = []
    for path in settings:
        code, out, err = run_as_operator(
            [
                "throw", "--settings", str(path), "--calibration", str(calibration),
                "--library", str(library), "--yes", "--json",
            ],
            env,
        )  # fmt: skip
        assert code == 0, err
        assert "has no passing driver report" in err, err
        assert err.count("press Enter") - err.count("the rig does not see a marker") == 1, err
        result = loads_strict(out)
        assert result["thrown"] and result["result"]["failure"] is None
        assert result["target_base_m"] is None  # the rig found the target: nobody gave it
        errors.append(result["result"]["error_m"])
    errors_m = np.array(errors)
    print(f"rig-measured errors (mm): {np.round(1e3 * errors_m, 1).tolist()}; labels - targets (mm): "
          f"{np.round(1e3 * np.linalg.norm(labels - targets, axis=1), 1).tolist()}")  # fmt: skip
    assert np.isfinite(errors_m).all() and np.median(errors_m) < MEDIAN_M, errors_m


def test_the_commands_say_what_to_pass_without_sim_or_settings(capsys):
    # in-process: the refusal is the commands' own (the console script runs the same `main`, in the
    # subprocesses above)
    for argv in (["train"], ["throw"], ["calibrate", "--robot"]):
        assert main(argv) == 2, argv
        lines = capsys.readouterr().err.strip().splitlines()
        assert len(lines) == 1 and "--settings S.json" in lines[0] and "--sim" in lines[0], lines
