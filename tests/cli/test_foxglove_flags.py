"""`--foxglove [PORT]`: track, replay and a session (demo, serve) serve their channels live and say where."""

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


def test_foxglove_beyond_loopback_needs_the_risk_accepted(capsys):
    argv = ["track", "--sim", "--duration", "0.2", "--foxglove", "0"]
    assert main([*argv, "--foxglove-host", "0.0.0.0"]) == 2
    err = capsys.readouterr().err
    assert "--foxglove-host 0.0.0.0: foxglove-sdk's server cannot check a token" in err
    assert "SSH tunnel" in err and "--foxglove-insecure-network" in err
    assert main([*argv, "--foxglove-insecure-network"]) == 2
    assert (
        "--foxglove-insecure-network does not apply without --foxglove-host beyond loopback" in capsys.readouterr().err
    )
    assert main(["track", "--sim", "--duration", "0.2", "--foxglove-host", "::1"]) == 2
    assert "--foxglove-host does not apply without --foxglove" in capsys.readouterr().err
    assert main([*argv, "--foxglove-host", "0.0.0.0", "--foxglove-insecure-network"]) == 0
    err = capsys.readouterr().err
    assert re.search(r"Foxglove live on ws://0\.0\.0\.0:\d+ ", err), err
    assert re.search(r"NOTE: Foxglove live listens on 0\.0\.0\.0:\d+ without authentication", err), err


def test_replay_refuses_foxglove_beyond_loopback_before_reading(capsys, tmp_path):
    assert main(["replay", str(tmp_path / "none.mcap"), "--foxglove", "0", "--foxglove-host", "10.0.0.1"]) == 2
    assert "--foxglove-host 10.0.0.1: " in capsys.readouterr().err


def test_serve_and_demo_refuse_foxglove_beyond_loopback_before_their_work(capsys):
    for command in (["serve"], ["demo"]):
        assert main([*command, "--foxglove", "0", "--foxglove-host", "192.168.1.5"]) == 2, command
        err = capsys.readouterr().err
        assert "--foxglove-host 192.168.1.5: foxglove-sdk's server cannot check a token" in err, (command, err)


def test_replay_plays_to_foxglove_and_refuses_what_the_player_cannot_do(capsys, tmp_path):
    run = tmp_path / "run.mcap"
    assert main(["track", "--sim", "--duration", "0.3", "--record", str(run), "--out", str(tmp_path / "a.jsonl")]) == 0
    rows = tmp_path / "rows.jsonl"
    capsys.readouterr()
    assert main(["replay", str(run), "--foxglove", "0", "--speed", "20", "--out", str(rows)]) == 0  # no client
    err = capsys.readouterr().err
    assert re.search(r"Foxglove's timeline is the recording's, t = \d+\.\d{3} to \d+\.\d{3} s: it plays at x20 ", err)
    assert rows.read_text() == (tmp_path / "a.jsonl").read_text()  # the rows as without --foxglove
    assert main(["replay", str(run), "--foxglove-wait"]) == 2
    assert "--foxglove-wait does not apply without --foxglove" in capsys.readouterr().err
    assert main(["replay", str(run), "--foxglove", "0", "--calibration", str(tmp_path / "c.json")]) == 2
    assert "--calibration does not apply with --foxglove (Foxglove's player serves the markers the" in (
        capsys.readouterr().err
    )
    assert main(["replay", str(run), "--foxglove", "0", "--speed", "500"]) == 2
    assert "--speed 500 with --foxglove: the player plays at x0.01 to x100" in capsys.readouterr().err


def test_a_session_is_served_from_a_writer_process_on_loopback(capsys):
    import argparse

    from wiithrow.app.cli.foxglove_flags import foxglove_session
    from wiithrow.app.foxglove.session_process_live import FoxgloveSessionProcessLive
    from wiithrow.app.session import simulated_session

    session = simulated_session(seed=1, calibration="true", quiet=True)
    args = argparse.Namespace(foxglove=0, foxglove_host=None, foxglove_insecure_network=False)
    live = foxglove_session(args, "demo", session)
    try:
        assert isinstance(live, FoxgloveSessionProcessLive) and live.process.alive() and live.host == "127.0.0.1"
    finally:
        live.close()
        session.close()
    err = capsys.readouterr().err
    assert re.search(r"wiithrow demo: Foxglove live on ws://127\.0\.0\.1:\d+ ", err), err
    assert not live.process.alive()  # closed: no orphan
