"""Recording a run (issue 14, part A): what the file holds, read back with the `mcap` package's
own reader (not with wiithrow's replay), and a recording that fails without stopping the tracking."""

import json
import os
import shutil
import signal
import subprocess
import sys
import time
from argparse import Namespace
from pathlib import Path

import pytest
from mcap.reader import NonSeekingReader, make_reader

from wiithrow.app.cli.commands.track import _simulated
from wiithrow.app.cli.main import main
from wiithrow.app.recording import FORMAT_VERSION, Recorder, replay_markers
from wiithrow.app.rig.source import newest_t

pytestmark = pytest.mark.filterwarnings("ignore::pytest.PytestUnraisableExceptionWarning")

TOPICS = {
    "/wiimote/0/reports": "wiithrow.HidReports",
    "/wiimote/1/reports": "wiithrow.HidReports",
    "/wiimote/0/dots": "wiithrow.Dots",
    "/wiimote/1/dots": "wiithrow.Dots",
    "/rig/steps": "wiithrow.RigStep",
    "/markers": "wiithrow.Markers",
    "/markers/scene": "foxglove.SceneUpdate",
    "/calibration": "wiithrow.Calibration",
    "/tf_static": "foxglove.FrameTransforms",  # the cameras' frames (a session's arm: /tf)
    "/rig/start": "wiithrow.TrackingStart",  # what replay counts t from: the rows equal track's
}


@pytest.fixture(scope="module")
def recorded(tmp_path_factory) -> Path:
    path = tmp_path_factory.mktemp("rec") / "run.mcap"
    assert (
        main(["track", "--sim", "--duration", "2", "--record", str(path), "--out", str(path.with_suffix(".jsonl"))])
        == 0
    )
    return path


def test_the_file_holds_every_channel_with_its_schema_in_time_order(recorded):
    with recorded.open("rb") as f:
        reader = make_reader(f)
        summary = reader.get_summary()
        assert summary is not None
        topics = {c.topic: summary.schemas[c.schema_id].name for c in summary.channels.values()}
        assert topics == TOPICS
        assert all(c.message_encoding == "json" for c in summary.channels.values())
        assert all(s.encoding == "jsonschema" for s in summary.schemas.values())
        counts = {c.topic: summary.statistics.channel_message_counts[i] for i, c in summary.channels.items()}
        # 2 s at 100 Hz: about 200 frames per camera and as many tracked frames
        assert 190 <= counts["/wiimote/0/dots"] <= 205 and 190 <= counts["/wiimote/1/dots"] <= 205
        assert abs(counts["/markers"] - counts["/wiimote/0/dots"]) <= 2
        assert counts["/wiimote/0/reports"] >= counts["/wiimote/0/dots"]  # every report, start-up's too
        assert counts["/calibration"] == 1 and counts["/tf_static"] >= 1
        metadata = {m.name: m.metadata for m in reader.iter_metadata()}
        assert metadata["wiithrow"]["format_version"] == str(FORMAT_VERSION)
        last: dict[str, int] = {}
        for _, channel, message in reader.iter_messages(log_time_order=False):
            assert message.log_time >= last.get(channel.topic, 0), channel.topic
            last[channel.topic] = message.log_time
    with recorded.open("rb") as f:
        tf = [json.loads(m.data) for _, _, m in make_reader(f).iter_messages(topics=["/tf_static"])]
    assert {t["child_frame_id"] for t in tf[0]["transforms"]} == {"camera_0", "camera_1"}
    assert 35 <= counts["/markers/scene"] <= 45  # 20 Hz for 2 s
    with recorded.open("rb") as f:
        scene = [json.loads(m.data) for _, _, m in make_reader(f).iter_messages(topics=["/markers/scene"])][-1]
    entity = scene["entities"][0]
    assert entity["frame_id"] == "link1" and len(entity["spheres"]) == len(entity["texts"]) == 4
    assert sorted(t["text"] for t in entity["texts"]) == ["0", "1", "2", "3"]


def test_replay_tracks_the_recorded_markers_exactly(recorded):
    live = []
    with recorded.open("rb") as f:
        for _, _, message in make_reader(f).iter_messages(topics=["/markers"], log_time_order=False):
            live.append(json.loads(message.data))
    replay, frames = replay_markers(recorded)
    assert replay.end is None and len(frames) == len(live) > 150
    for m, f in zip(live, frames):
        assert m["t"] == f.t and m["ids"] == f.ids.tolist()
        assert m["positions"] == f.position.tolist() and m["views"] == f.n_views.tolist()
    assert {i for m in live for i in m["ids"]} == {0, 1, 2, 3}


def _rig(seed: int = 0):
    rig, clock, _frame = _simulated(Namespace(cameras=None, realtime=False, speed=None, seed=seed), None)
    return rig, clock


def _run(rig, clock, seconds: float) -> int:
    frames = 0
    end = clock.now() + seconds
    while clock.now() < end:
        since = newest_t(rig)
        rig.poll()
        frames += len(rig.tracked_since(since))
        clock.sleep(0.005)
    return frames


def test_a_full_disk_stops_the_recording_with_one_line_and_tracking_goes_on(tmp_path):
    rig, clock = _rig()
    errors: list[str] = []
    recorder = Recorder(tmp_path / "full.mcap", clock, on_error=errors.append)
    recorder.start(rig)
    rig.connect()
    assert _run(rig, clock, 0.5) > 30
    full = os.open("/dev/full", os.O_WRONLY)
    os.dup2(full, recorder.sink._file.fileno())  # from now on every write fails: No space left on device
    os.close(full)
    assert _run(rig, clock, 2.0) > 150  # tracking goes on
    recorder.close()
    rig.close()
    assert len(errors) == 1 and "No space left on device" in errors[0] and "tracking goes on" in errors[0]
    # the recorder stopped listening: nothing but the rig's own listener of each driver's reports is left
    assert len(rig.events) == 0 and all(len(d.decoder.reports) == 1 for d in rig.drivers)


def test_a_vanished_folder_stops_the_recording(tmp_path):
    rig, clock = _rig()
    errors: list[str] = []
    recorder = Recorder(tmp_path / "sub" / "run.mcap", clock, on_error=errors.append)
    recorder.start(rig)
    rig.connect()
    _run(rig, clock, 0.3)
    shutil.rmtree(tmp_path / "sub")
    assert _run(rig, clock, 2.0) > 150
    recorder.close()
    assert len(errors) == 1 and "vanished" in errors[0]


@pytest.mark.slow
def test_a_recorder_killed_with_sigkill_leaves_all_but_the_last_second(tmp_path):
    path = tmp_path / "killed.mcap"
    wiithrow = str(Path(sys.executable).with_name("wiithrow"))
    proc = subprocess.Popen(
        [
            wiithrow,
            "track",
            "--sim",
            "--realtime",
            "--duration",
            "60",
            "--record",
            str(path),
            "--out",
            str(tmp_path / "rows.jsonl"),
        ],
        stderr=subprocess.DEVNULL,
    )
    try:
        deadline = time.monotonic() + 60
        while not (path.exists() and path.stat().st_size > 20_000) and time.monotonic() < deadline:
            time.sleep(0.1)
        time.sleep(2.5)
        killed_at = time.time()  # the log times are Unix time (the rig's clock mapped once)
        proc.send_signal(signal.SIGKILL)
        proc.wait(10)
    finally:
        if proc.poll() is None:
            proc.kill()
    last: dict[str, int] = {}
    with path.open("rb") as f:
        try:
            for _, channel, message in NonSeekingReader(f).iter_messages(log_time_order=False):
                last[channel.topic] = message.log_time
        except Exception:
            pass  # the unfinished chunk at the end
    assert {"/wiimote/0/reports", "/wiimote/1/reports", "/markers", "/calibration"} <= set(last)
    lost_s = killed_at - last["/markers"] / 1e9
    assert 0 <= lost_s <= 1.5  # at most one second (a chunk) lost, plus slack for a loaded machine
    replay, frames = replay_markers(path)
    assert replay.end is not None and "cut short" in replay.end and len(frames) > 150


def test_a_step_the_rig_refuses_is_replayed_alike(tmp_path):
    """A frame older than the one before makes the rig refuse the rest of that call (as the MuJoCo
    world's start-up batch can): the recording says so, and the replay loses the same frames."""
    import numpy as np

    from wiithrow.app.cli.bench.tracking import decoders_and_pipeline, recorded_reports
    from wiithrow.clock import SimClock
    from wiithrow.vision.errors import VisionError

    reports, Ps = recorded_reports(1.0, np.random.default_rng(1), 2)
    clock = SimClock()
    decoders, rig = decoders_and_pipeline(Ps, clock)
    for c, decoder in enumerate(decoders):  # the raw reports reach the recording as a live rig's do
        decoder.subscribe(rig.reports_listener(c))
    recorder = Recorder(tmp_path / "refused.mcap", clock)
    recorder.start(rig)
    refused = 0
    spoiled = False
    for i, (c, t, data) in enumerate(reports):
        frames = decoders[c].decode([(t, data)])
        if i > 80 and c == 0 and not spoiled:  # the same report again, as if sent 25 ms earlier: out of order
            frames += decoders[c].decode([(t - 0.025, data)]) + decoders[c].decode([(t + 0.004, data)])
            spoiled = True
        try:
            rig.process(c, frames)
        except VisionError:
            refused += 1
    recorder.close()
    assert refused == 1
    with (tmp_path / "refused.mcap").open("rb") as f:
        live = [
            json.loads(m.data) for _, _, m in make_reader(f).iter_messages(topics=["/markers"], log_time_order=False)
        ]
    replay, frames = replay_markers(tmp_path / "refused.mcap")
    assert replay.refused == 1 and len(frames) == len(live) > 90
    assert all(m["t"] == f.t and m["positions"] == f.position.tolist() for m, f in zip(live, frames))


def test_what_waits_is_flushed_within_a_second_when_the_rig_falls_silent(tmp_path):
    rig, clock = _rig()
    path = tmp_path / "silent.mcap"
    recorder = Recorder(path, clock)
    recorder.start(rig)
    rig.connect()
    _run(rig, clock, 0.4)  # less than a second of the run's clock: nothing flushed by the writes themselves
    written = recorder.messages
    time.sleep(1.6)  # no more polls: the recorder's own thread flushes the chunk
    seen = 0
    with path.open("rb") as f:
        try:
            for _ in NonSeekingReader(f).iter_messages(log_time_order=False):
                seen += 1
        except Exception:
            pass  # no footer yet: the file is still being written
    recorder.close()
    rig.close()
    assert written > 100 and seen == written
