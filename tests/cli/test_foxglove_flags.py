"""`--foxglove [PORT]`: track and replay serve their channels live and say where."""

from __future__ import annotations

import re

from wiithrow.app.cli.main import main


def test_track_and_replay_serve_foxglove_live_on_loopback(capsys, tmp_path):
    run = tmp_path / "run.mcap"
    assert main(["track", "--sim", "--duration", "0.3", "--record", str(run), "--foxglove", "0"]) == 0
    err = capsys.readouterr().err
    assert re.search(r"wiithrow track: Foxglove live on ws://127\.0\.0\.1:\d+ ", err), err
    assert main(["replay", str(run), "--foxglove", "0"]) == 0
    err = capsys.readouterr().err
    assert re.search(r"wiithrow replay: Foxglove live on ws://127\.0\.0\.1:\d+ ", err), err


def test_a_bad_foxglove_port_is_one_line(capsys):
    assert main(["track", "--sim", "--duration", "0.1", "--foxglove", "70000"]) == 2
    assert "a port is 0-65535" in capsys.readouterr().err
