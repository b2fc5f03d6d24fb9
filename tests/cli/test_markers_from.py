"""`serve --markers-from` in one process takes the markers `track --publish` tracks in another
(two real processes on loopback; issue 14): every frame published arrives, with its latency; with
no source named, none is followed until the operator confirms it, and the publisher that asks to
be followed is named with its host, pid and command (issue 41)."""

import re
import signal
import subprocess
import sys
import time

import pytest

from wiithrow.app.cli.bench.publish import free_port, loopback_configs
from wiithrow.app.cli.main import main

WIITHROW = [sys.executable, "-m", "wiithrow.app.cli.main"]

#: How long `serve` keeps listening after the tracker has finished before it is stopped (Ctrl-C):
#: loopback frames arrive within milliseconds; this is for a loaded machine. Its `--duration` is only
#: the backstop of a serve nobody stops.
GRACE_S = 5.0


def stop_serve(serve: subprocess.Popen) -> str:
    """Ctrl-C `serve` after `GRACE_S` (it then prints its summary and exits 0); its stderr."""
    time.sleep(GRACE_S)
    serve.send_signal(signal.SIGINT)
    _out, err = serve.communicate(timeout=60)
    return err


@pytest.mark.slow
def test_serve_takes_the_markers_track_publishes_on_another_process(tmp_path):
    listen_cfg, connect_cfg = loopback_configs(tmp_path, free_port())
    serve = subprocess.Popen(
        WIITHROW
        + ["serve", "--markers-from", "wiithrow/lab", "--zenoh-config", str(listen_cfg)]
        + ["--port", "0", "--duration", "25"],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    try:
        track = subprocess.run(
            WIITHROW
            + ["track", "--sim", "--realtime", "--duration", "3", "--publish", "--rig-name", "lab"]
            + ["--zenoh-config", str(connect_cfg), "--wait-subscriber", "20"],
            capture_output=True,
            text=True,
            timeout=60,
        )
        err = stop_serve(serve)
    finally:
        if serve.poll() is None:
            serve.kill()
            serve.wait()
    assert track.returncode == 0, track.stderr
    assert serve.returncode == 0, err
    published = int(re.search(r"published (\d+) marker frames", track.stderr).group(1))
    # 3 s at 100 Hz would be 300 frames; a loaded machine tracks fewer in real time (219 at a load of 5 on
    # 2 cores; 1 and 3 for a niced run at a load of 13), so the rate is the benchmark's business
    # (`bench publish`): here, that frames flowed and that every one published arrived
    assert published > 0
    received = re.search(r"received (\d+) marker frames from wiithrow/lab; adopted (\d+)", err)
    assert received is not None, err
    assert int(received.group(1)) == published
    # no source named and nobody confirmed one: nothing adopted, and the operator was told who asks
    assert int(received.group(2)) == 0, err
    source = re.search(r"as source ([0-9a-f]+), stream ([0-9a-f]+)", track.stderr)
    assert source is not None, track.stderr
    asks = [line for line in err.splitlines() if "asks to be followed" in line]
    assert len(asks) == 1 and f"source {source.group(1)}, stream {source.group(2)} (host " in asks[0], err
    assert ": python" in asks[0] and " track --sim --realtime " in asks[0]  # its command
    assert "Traceback" not in err


def test_markers_from_refuses_what_belongs_to_the_tracking_host(capsys):
    argv = ["serve", "--markers-from", "wiithrow/lab", "--calibration", "c.json", "--port", "0"]
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "--calibration does not apply with --markers-from" in err


def test_markers_from_refuses_a_recording_here(capsys, tmp_path):
    """No remote is read on the dashboard's host with --markers-from: a recording there would hold
    almost nothing, so it is refused and the tracking host is named."""
    argv = ["serve", "--markers-from", "wiithrow/lab", "--record", str(tmp_path / "s.mcap"), "--port", "0"]
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "--record does not apply with --markers-from" in err
    assert list(tmp_path.iterdir()) == []


@pytest.mark.slow
def test_serve_follows_the_named_source_and_prints_what_it_refused(tmp_path):
    """`serve --markers-from --markers-source ID` with `track --publish` under that Zenoh id (its config's
    `id`) and a rogue process publishing five kinds of fake frames: the operator is told whom the markers
    follow and what was refused, by reason, and at the end the counts."""
    import json

    listen_cfg, connect_cfg = loopback_configs(tmp_path, free_port())
    tracker_id = "1dea5eed"
    tracker_cfg = tmp_path / "tracker.json5"
    tracker_cfg.write_text(json.dumps({**json.loads(connect_cfg.read_text()), "id": tracker_id}))
    serve = subprocess.Popen(
        WIITHROW
        + ["serve", "--markers-from", "wiithrow/lab", "--markers-source", tracker_id]
        + ["--zenoh-config", str(listen_cfg), "--port", "0", "--duration", "30"],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    rogue = forger = None
    try:
        # a process of the same user (it signs): each kind refused for what it holds
        rogue = subprocess.Popen(
            [sys.executable, "-m", "tests.helpers.rogue_publisher", "--signed", str(connect_cfg), "lab"]
            + ["other_rig,other_source,garbage,nan,out_of_volume", "30"],
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
        )
        # and one without the secret: refused unread
        forger = subprocess.Popen(
            [sys.executable, "-m", "tests.helpers.rogue_publisher", str(connect_cfg), "lab", "other_source", "30"],
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
        )
        track = subprocess.run(
            WIITHROW
            + ["track", "--sim", "--realtime", "--duration", "3", "--publish", "--rig-name", "lab"]
            + ["--zenoh-config", str(tracker_cfg), "--wait-subscriber", "20"],
            capture_output=True,
            text=True,
            timeout=60,
        )
        for process in (rogue, forger):
            process.terminate()
            process.wait(timeout=10)
        err = stop_serve(serve)
    finally:
        for process in (serve, rogue, forger):
            if process is not None and process.poll() is None:
                process.kill()
                process.wait()
    assert track.returncode == 0, track.stderr
    assert serve.returncode == 0, err
    assert f"as source {tracker_id}, stream " in track.stderr  # announced at start
    assert f"markers from wiithrow/lab: following source {tracker_id}, stream " in err
    assert "(the one named with --markers-source)" in err
    summaries = re.findall(r"markers from wiithrow/lab: refused (\d+) frames \(([^)]*)\)", err)
    assert summaries, err
    assert any(
        all(k in s[1] for k in ("malformed", "other_rig", "other_source", "non_finite", "out_of_volume"))
        for s in summaries
    )
    assert any("unauthenticated" in s[1] for s in summaries) and "this user's secret" in err
    published = int(re.search(r"published (\d+) marker frames", track.stderr).group(1))
    latency = re.search(r"received \d+ marker frames from wiithrow/lab, latency p50 ([\d.]+) ms, p99 ([\d.]+)", err)
    assert latency is not None, err
    # figures, not rates (`bench publish` measures them): positive, ordered, and within the serve's 30 s
    # (a frame cannot arrive later than that); p99 was 1,020 ms once under a load of 4 beside the suite
    assert 0 < float(latency.group(1)) <= float(latency.group(2)) < 30_000.0
    final = re.search(r"received (\d+) marker frames .*; adopted (\d+), refused (.*)", err)
    assert final is not None, err
    received, adopted = int(final.group(1)), int(final.group(2))
    refusals = final.group(3).split(" (")[0]  # (then the camera frames refused, not counted here)
    counts = {reason: int(n) for n, reason in re.findall(r"(\d+) (\w+)", refusals)}
    # every frame received is adopted or refused before it (a stale frame is adopted, then not kept)
    assert received == adopted + sum(n for reason, n in counts.items() if reason != "stale"), err
    # The named source is followed: its frames are adopted, all of them on a quiet machine. Under a
    # load of 4 the real-time simulated rig of `track` can glitch and a frame of it fail a check
    # (a CI run: 197 of 198 adopted; which check, its output did not say), refused as it should be: at most 2%.
    real_refused = published - adopted
    assert 0 <= real_refused <= published // 50, err
    assert counts.get("unauthenticated", 0) > 0 and counts.get("seq", 0) == 0, err
    rogue_kinds = ("malformed", "other_rig", "other_source", "non_finite", "out_of_volume")
    rogue_counts = [counts.get(k, 0) for k in rogue_kinds]
    # one of each kind per round (and a refused real frame may have been counted under one of them)
    assert min(rogue_counts) > 0 and max(rogue_counts) - min(rogue_counts) <= 1 + real_refused, err
    assert "Traceback" not in err
