"""Feedback at the terminal (issue 21, item 7): the long commands show a progress bar when stderr is
a terminal, and none with --json or into a pipe. The terminal here is a pty nobody sized (0 rows,
0 columns, as `script` gives without a terminal): tqdm hid every bar on it until
`wiithrow.app.progress` gave such a terminal a height."""

from __future__ import annotations

import os
import pty
import re
import subprocess
import sys
from pathlib import Path

import pytest

WIITHROW = str(Path(sys.executable).with_name("wiithrow"))


def stderr_of(argv: list[str], env: dict[str, str], *, terminal: bool) -> str:
    """What `wiithrow argv` writes on stderr, a pty's (unsized) or a pipe's."""
    if not terminal:
        return subprocess.run([WIITHROW, *argv], capture_output=True, text=True, env=env, timeout=300).stderr
    leader, follower = pty.openpty()
    child = subprocess.Popen([WIITHROW, *argv], stdout=subprocess.DEVNULL, stderr=follower, env=env)
    os.close(follower)
    chunks = []
    while True:
        try:
            chunk = os.read(leader, 65536)
        except OSError:  # the child closed its end
            break
        if not chunk:
            break
        chunks.append(chunk)
    child.wait(timeout=300)
    os.close(leader)
    return b"".join(chunks).decode("utf-8", "replace")


@pytest.fixture()
def env(tmp_path):
    return {**os.environ, "WIITHROW_CACHE_DIR": str(tmp_path / "cache")}


@pytest.mark.parametrize(
    "terminal, json_flag, shown", [(True, False, True), (True, True, False), (False, False, False)]
)
def test_calibrate_robot_sim_shows_its_poses_on_a_terminal_only(tmp_path, env, terminal, json_flag, shown):
    argv = ["calibrate", "--robot", "--sim", "--world", "kinematic", "--points", "6", "--out", str(tmp_path / "c.json")]
    err = stderr_of([*argv, *(["--json"] if json_flag else [])], env, terminal=terminal)
    assert err.splitlines()[0].strip() == "world: kinematic (simulated: the planner's own models)", err
    # a bar counting the poses (its last state may be cleared before tqdm redraws it at 6/6: the bar
    # redraws at most every 0.1 s and is removed at the end; a CI run ended its screen at 5/6)
    assert bool(re.search(r"calibration poses: .*\b[1-6]/6\b", err)) == shown, err


def test_train_shows_its_throws_on_a_terminal(tmp_path, env, sim_world):
    calibration = str(sim_world.true_calibration().save(tmp_path / "cal.json"))
    argv = ["train", "--sim", "--world", "kinematic", "--throws", "5", "--calibration", calibration]
    err = stderr_of([*argv, "--out", str(tmp_path / "l.json")], env, terminal=True)
    assert re.search(r"training throws: .*\b[1-5]/5\b", err), err
    err = stderr_of([*argv, "--out", str(tmp_path / "m.json"), "--json"], env, terminal=True)
    assert "training throws:" not in err and "throw  1/5" not in err, err
