"""`wiithrow train` runs the dashboard's training procedure (`TrainingRun`, through the session's
training steps): its progress saved after every throw beside the library, a throw whose landing the
rig does not see or whose ball was lost marked failed and retried or skipped (`--on-lost`, or the
operator's answer at a prompt), a stop or an error keeping every measured throw, `--resume` taking the
run up. On the kinematic world with its true calibration (no robot calibration), 6 throws a run.

The world's hooks: the simulated operator does not put the landing marker down for chosen
measurements (the rig then sees none: an unseen landing), or the ball slips out of the hand as it is
loaded (a lost ball: the throw ends at its safe boundary, `ThrowFailed`)."""

from __future__ import annotations

import json
import os
import pty
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from tests.helpers.strict_json import loads_strict
from wiithrow.app.cli.main import main
from wiithrow.app.errors import AppError
from wiithrow.app.throws.library_file import load_library
from wiithrow.app.throws.training_file import load_run, progress_path
from wiithrow.app.worlds.simulated import SimWorld

THROWS = 6
WIITHROW_PYTHON = sys.executable
ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture()
def calibration(sim_world, tmp_path):
    return str(sim_world.true_calibration().save(tmp_path / "cal.json"))


def train_argv(calibration: str, out: Path, *more: str) -> list[str]:
    return [
        "train", "--sim", "--world", "kinematic", "--calibration", calibration,
        "--throws", str(THROWS), "--out", str(out), "--json", *more,
    ]  # fmt: skip


def measured_in_file(library: Path) -> int:
    run = load_run(progress_path(library), library)
    return 0 if run is None else run.measured


def hide_landings(monkeypatch, library: Path, hidden: set[int], *, raising: BaseException | None = None):
    """The simulated operator does not put the marker down at the `hidden` measurements (1-based,
    counted over the run), or raises `raising` there. Returns, per measurement, how many measured
    throws the progress file held as it began."""
    original = SimWorld.place_landing_marker_at
    in_file: list[int] = []

    def place(self, landing_base):
        in_file.append(measured_in_file(library))
        if len(in_file) in hidden:
            if raising is not None:
                raise raising
            return False
        return original(self, landing_base)

    monkeypatch.setattr(SimWorld, "place_landing_marker_at", place)
    return in_file


def test_an_unseen_landing_without_on_lost_stops_and_keeps_every_measured_throw(
    tmp_path, capsys, monkeypatch, calibration
):
    """It gave prompts, then an error, and saved nothing. Off a terminal, without --on-lost, the run
    stops at the failed throw (exit 1) and its progress file keeps the throws measured before it."""
    library = tmp_path / "lib.json"
    in_file = hide_landings(monkeypatch, library, {3})
    assert main(train_argv(calibration, library)[:-1]) == 1  # without --json: the summary lines
    err = capsys.readouterr().err
    assert in_file[:3] == [0, 1, 2]  # each measurement began with every earlier throw in the file
    assert "throw 3/6" in err and "landing" in err, err
    last = err.strip().splitlines()[-1]
    assert "2 measured throws kept in" in last and str(progress_path(library)) in last and "--resume" in last, last
    run = load_run(progress_path(library), library)
    assert run is not None and run.measured == 2 and run.index == 2 and run.current is not None
    assert run.current.state == "failed" and "does not see a marker" in run.current.note
    assert not library.exists()


@pytest.mark.parametrize("policy, kept, skipped", [("retry", THROWS, 0), ("skip", THROWS - 1, 1)])
def test_an_unseen_landing_is_retried_or_skipped_as_on_lost_says(
    tmp_path, capsys, monkeypatch, calibration, policy, kept, skipped
):
    library = tmp_path / "lib.json"
    in_file = hide_landings(monkeypatch, library, {2})
    assert main(train_argv(calibration, library, "--on-lost", policy)) == 0
    captured = capsys.readouterr()
    result = loads_strict(captured.out)
    assert result["throws"] == kept and result["skipped"] == skipped, captured.err
    assert len(load_library(library)) == kept
    assert not progress_path(library).exists()  # finished: the library is the record now
    # no measured throw was lost on the way: the file held every earlier one at each measurement
    assert in_file == sorted(in_file) and in_file[-1] == kept - 1, in_file
    assert f"throw 2/{THROWS}" in captured.err and policy in captured.err, captured.err


def test_a_lost_ball_is_retried_and_every_other_throw_kept(tmp_path, capsys, monkeypatch, calibration):
    library = tmp_path / "lib.json"
    original = SimWorld.load_ball
    loads: list[int] = []

    def slips_once(self, cancel=None):
        loads.append(measured_in_file(library))
        if len(loads) == 4:
            raise RuntimeError("the ball slipped out of the hand")
        return original(self, cancel)

    monkeypatch.setattr(SimWorld, "load_ball", slips_once)
    assert main(train_argv(calibration, library, "--on-lost", "retry")) == 0
    captured = capsys.readouterr()
    assert loads_strict(captured.out)["throws"] == THROWS
    assert loads[3:5] == [3, 3]  # the lost throw (the 4th) and its retry, with 3 measured in the file
    assert "the ball slipped out of the hand" in captured.err and "retry" in captured.err, captured.err


def test_retries_are_bounded_then_the_target_is_skipped(tmp_path, capsys, monkeypatch, calibration):
    from wiithrow.app.cli.train_steps import RETRIES_PER_TARGET

    library = tmp_path / "lib.json"
    hide_landings(monkeypatch, library, set(range(2, 3 + RETRIES_PER_TARGET)))  # throw 2 and every retry of it
    assert main(train_argv(calibration, library, "--on-lost", "retry")) == 0
    captured = capsys.readouterr()
    result = loads_strict(captured.out)
    assert result["throws"] == THROWS - 1 and result["skipped"] == 1, captured.err
    assert f"after {RETRIES_PER_TARGET} retries" in captured.err, captured.err


def test_a_stopped_run_is_refused_without_resume_and_finished_with_it(tmp_path, capsys, monkeypatch, calibration):
    library = tmp_path / "lib.json"
    hide_landings(monkeypatch, library, {4})
    assert main(train_argv(calibration, library, "--on-lost", "stop")) == 1
    assert "3 measured throws kept" in capsys.readouterr().err
    saved = load_run(progress_path(library), library)
    assert saved is not None and saved.measured == 3 and saved.current is not None
    assert saved.current.state == "failed"
    before = progress_path(library).read_bytes()
    monkeypatch.undo()

    # a new run would overwrite it: refused in one line, saying how to resume or discard it
    assert main(train_argv(calibration, library)) == 2
    lines = capsys.readouterr().err.strip().splitlines()
    assert len(lines) == 1 and "--resume" in lines[0] and str(progress_path(library)) in lines[0], lines
    assert "3 of 6 measured" in lines[0] and "remove it" in lines[0], lines
    assert progress_path(library).read_bytes() == before

    # resumed: the failed throw 4 is decided again (retried, as --on-lost says), the three measured kept
    original = SimWorld.load_ball
    thrown: list[int] = []

    def counted(self, cancel=None):
        thrown.append(1)
        return original(self, cancel)

    monkeypatch.setattr(SimWorld, "load_ball", counted)
    argv = [a for a in train_argv(calibration, library) if a not in ("--throws", str(THROWS))]
    assert main([*argv, "--resume", "--on-lost", "retry"]) == 0
    assert len(thrown) == THROWS - 3  # throws 4 (again), 5 and 6: none of the measured thrown again
    captured = capsys.readouterr()
    result = loads_strict(captured.out)
    assert result["throws"] == THROWS and result["skipped"] == 0, captured.err
    trained = load_library(library)
    kept = [t.measured for t in saved.throws if t.state == "measured"]
    assert np.allclose(trained.landings[:3], kept)  # the three measured before the stop, not thrown again
    assert "resumed" in captured.err and not progress_path(library).exists()


def test_resume_refuses_throws_and_a_missing_run(tmp_path, capsys, calibration):
    library = tmp_path / "lib.json"
    assert main([*train_argv(calibration, library), "--resume"]) == 2
    line = capsys.readouterr().err.strip()
    assert "--throws" in line and "--resume" in line and len(line.splitlines()) == 1, line
    argv = [a for a in train_argv(calibration, library) if a not in ("--throws", str(THROWS))] + ["--resume"]
    assert main(argv) == 2
    line = capsys.readouterr().err.strip()
    assert "no training run" in line and str(progress_path(library)) in line and len(line.splitlines()) == 1, line


@pytest.mark.parametrize(
    "raising, code, needle",
    [
        (AppError("remote 2 stopped answering"), 2, "remote 2 stopped answering"),
        (KeyboardInterrupt(), 130, "interrupted"),
    ],
    ids=["error", "interrupt"],
)
def test_an_error_mid_run_keeps_the_measured_throws_and_says_how_to_resume(
    tmp_path, capsys, monkeypatch, calibration, raising, code, needle
):
    library = tmp_path / "lib.json"
    hide_landings(monkeypatch, library, {3}, raising=raising)
    assert main(train_argv(calibration, library, "--on-lost", "retry")) == code
    lines = capsys.readouterr().err.strip().splitlines()
    assert needle in lines[-1] and "2 measured throws kept" in lines[-1] and "--resume" in lines[-1], lines
    assert measured_in_file(library) == 2


# -- the operator's prompt, at a terminal (a pseudo-terminal) and through a pipe --------------------------

HOOKED_MAIN = """
import sys
from wiithrow.app.worlds.simulated import SimWorld
original = SimWorld.place_landing_marker_at
calls = []
def place(self, landing_base):
    calls.append(1)
    if len(calls) == 2:
        return False
    return original(self, landing_base)
SimWorld.place_landing_marker_at = place
from wiithrow.app.cli.main import main
sys.exit(main(sys.argv[1:]))
"""


def answer_prompts(argv: list[str], answers: list[str], *, terminal: bool) -> tuple[int, str, str]:
    """Run `wiithrow argv` (the second landing hidden) with stdin a pseudo-terminal or a pipe, and
    answer each "r retry" prompt with the next of `answers`, once it is shown."""
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(ROOT), os.environ.get("PYTHONPATH", "")])}
    if terminal:
        leader, follower = pty.openpty()
        child = subprocess.Popen(
            [WIITHROW_PYTHON, "-c", HOOKED_MAIN, *argv], stdin=follower, stdout=subprocess.PIPE,
            stderr=subprocess.PIPE, env=env,
        )  # fmt: skip
        os.close(follower)

        def write(text: str) -> None:
            os.write(leader, text.encode())
    else:
        child = subprocess.Popen(
            [WIITHROW_PYTHON, "-c", HOOKED_MAIN, *argv], stdin=subprocess.PIPE, stdout=subprocess.PIPE,
            stderr=subprocess.PIPE, env=env,
        )  # fmt: skip
        assert child.stdin is not None

        def write(text: str) -> None:
            assert child.stdin is not None
            child.stdin.write(text.encode())
            child.stdin.flush()

    assert child.stderr is not None and child.stdout is not None
    err: list[str] = []
    pending = list(answers)
    deadline = time.monotonic() + 300
    for raw in child.stderr:
        line = raw.decode("utf-8", "replace")
        err.append(line)
        if "r retry" in line and pending:
            write(pending.pop(0))
        assert time.monotonic() < deadline, "".join(err)
    out = child.stdout.read().decode()
    child.wait(timeout=60)
    if terminal:
        os.close(leader)
    return child.returncode, out, "".join(err)


def test_the_operator_skips_an_unseen_landing_at_the_terminal_prompt(tmp_path, calibration):
    library = tmp_path / "lib.json"
    code, out, err = answer_prompts(train_argv(calibration, library), ["s\n"], terminal=True)
    assert code == 0, err
    assert "r retry" in err and f"throw 2/{THROWS}" in err
    result = json.loads(out)
    assert result["throws"] == THROWS - 1 and result["skipped"] == 1


def test_the_prompt_through_a_pipe_asks_again_until_it_is_answered(tmp_path, calibration):
    library = tmp_path / "lib.json"
    code, out, err = answer_prompts(
        train_argv(calibration, library, "--on-lost", "ask"), ["maybe\n", "r\n"], terminal=False
    )
    assert code == 0, err
    assert err.count("r retry") == 2, err  # "maybe" is no answer: asked again
    result = json.loads(out)
    assert result["throws"] == THROWS and result["skipped"] == 0
