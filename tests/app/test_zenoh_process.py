"""`--publish`'s writer process (`ZenohProcessPublisher`, issue 23): a subscriber in another session
gets from it the very messages the in-process `RigPublisher` puts; a stopped writer never stalls
the hand-over and its loss is counted and seen in `seq`; a killed one is one line and the
tracking goes on; a session that cannot open is one line; the writer ends with its owner."""

from __future__ import annotations

import os
import signal
import socket
import subprocess
import sys
import time

import numpy as np
import pytest

from tests.app.test_writer_process import END_WITHIN_S, _gone
from tests.helpers.command_lines import after_opening
from wiithrow.app.channels import json_messages as jm
from wiithrow.app.channels import records
from wiithrow.app.channels import registry as r
from wiithrow.app.channels.frame_ring import FrameRing
from wiithrow.app.channels.sink_process import RING_SLOTS
from wiithrow.app.channels.zenoh_sink import RigPublisher, ZenohProcessPublisher
from wiithrow.app.cli.bench.publish import loopback_configs
from wiithrow.app.cli.main import main
from wiithrow.app.network.messages import Sender, markers_message
from wiithrow.app.network.subscriber import Subscription
from wiithrow.app.network.zenoh_session import open_session
from wiithrow.clock import SimClock
from wiithrow.vision.tracked_frame import TrackedFrame
from wiithrow.vision.wiimote.frames import IRFrame
from wiithrow.vision.wiimote.protocol import Button

CAMERAS = ["cam0", "cam 1"]  # (a name a key chunk cannot hold: the same '_' either way)


def _tracked(rng: np.random.Generator, t: float, n: int) -> TrackedFrame:
    velocity = rng.normal(size=(n, 3))
    velocity[rng.random((n, 3)) < 0.2] = np.nan  # a new track has no velocity yet: null
    return TrackedFrame(
        t,
        rng.integers(0, 1000, n),
        rng.normal(size=(n, 3)),
        velocity,
        rng.normal(size=(n, 3)) * 1e-7,  # sub-micrometre: the payload's rounding is exercised
        rng.random(n) > 0.3,
        rng.integers(0, 5, n),
    )


def _camera_frame(rng: np.random.Generator, t: float) -> IRFrame:
    dots = rng.uniform(0, 1023, (4, 2))
    dots[rng.random(4) < 0.4] = np.nan  # empty slots: null
    return IRFrame(t + 0.003, t, int(1000 * t), 0x33, dots, rng.uniform(1, 6, 4), Button(0))


def _drain(subscription: Subscription, count: int, timeout_s: float = 30.0, announced: list | None = None) -> list:
    """`count` samples of the frames' keys (the publisher's announcements, one a second, to `announced`)."""
    got = []
    end = time.monotonic() + timeout_s
    while len(got) < count and time.monotonic() < end:
        sample = subscription.get(0.05)
        if sample is not None and sample.key.endswith("/publisher"):
            if announced is not None:
                announced.append(sample.decode())
        elif sample is not None:
            got.append(sample)
    return got


def _without_who_and_when(sample) -> tuple[str, dict]:
    payload = sample.decode()
    rig = payload.pop("rig")
    for field in ("source", "stream", "sent"):
        payload.pop(field)
    return sample.key.replace(f"wiithrow/{rig}/", ""), payload


def test_a_subscriber_gets_the_same_messages_from_the_writer_process_as_in_process():
    rng = np.random.default_rng(0)
    frames = [(_camera_frame(rng, 0.01 * k), _camera_frame(rng, 0.01 * k + 0.002)) for k in range(60)]
    tracked = [_tracked(rng, 0.01 * k + 0.004, n) for k, n in enumerate([0, 1, 2, 3, 4, records.MAX_MARKERS] * 10)]
    throw = {"index": 3, "error_m": 0.0123456789, "landing": [1.5, -0.25, 0.0], "ok": True, "note": None}
    subscriber_session, inproc_session = open_session(), open_session()
    process = ZenohProcessPublisher("process", CAMERAS, "link1", clock=SimClock())
    try:
        subscriptions = {rig: Subscription(subscriber_session, f"wiithrow/{rig}/**") for rig in ("inproc", "process")}
        inproc = RigPublisher(inproc_session, "inproc", CAMERAS, "link1")
        assert inproc.wait_for_subscribers(20.0) and process.wait_for_subscribers(20.0)
        before = time.time()
        for publisher in (inproc, process):
            for (first, second), frame in zip(frames, tracked):
                publisher.publish_dots(0, first)
                publisher.publish_dots(1, second)
                publisher.publish_markers(frame)
        inproc.publish_throw(7, throw)
        process.post(r.THROWS.topic, 0, jm.throw_message(0.0, {"index": 7, "outcome": throw}))  # a session's throw
        assert process.flush(20.0)
        expected = 3 * len(tracked) + 1
        announced: dict[str, list] = {"inproc": [], "process": []}
        got = {rig: _drain(sub, expected, announced=announced[rig]) for rig, sub in subscriptions.items()}
        after = time.time()
        inproc.close()
    finally:
        process.close()
        inproc_session.close()
        subscriber_session.close()
    assert len(got["inproc"]) == len(got["process"]) == expected
    for rig in ("inproc", "process"):  # a subscriber reads each key in order (one publisher per key)
        for key in {s.key for s in got[rig]}:
            seqs = [s.decode()["seq"] for s in got[rig] if s.key == key]
            assert seqs == list(range(len(seqs)))

    def by_key(rig: str) -> dict[str, list[dict]]:
        messages: dict[str, list[dict]] = {}
        for sample in got[rig]:
            key, payload = _without_who_and_when(sample)
            messages.setdefault(key, []).append(payload)
        return messages

    inproc_messages, process_messages = by_key("inproc"), by_key("process")
    assert sorted(process_messages) == ["cameras/cam0/dots", "cameras/cam_1/dots", "markers", "throws"]
    assert process_messages == inproc_messages  # every field but who sent it and when, equal
    # who: the writer process's own Zenoh session, the stream it told; when: as it put them
    payloads = [s.decode() for s in got["process"]]
    assert {(p["source"], p["stream"]) for p in payloads} == {(process.source, process.stream)}
    assert process.source not in {str(subscriber_session.zid()), str(inproc_session.zid())}
    assert all(before <= p["sent"] <= after for p in payloads)
    # where: the tracking process (this one), not its writer process, as the in-process publisher says
    assert announced["process"] and announced["inproc"]
    origins = {rig: {(a["host"], a["pid"], a["command"]) for a in announced[rig]} for rig in announced}
    assert origins["process"] == origins["inproc"] and {o[1] for o in origins["process"]} == {os.getpid()}
    assert process.summary() == (
        f"published {len(tracked)} marker frames, {2 * len(frames)} camera frames and 1 throws under wiithrow/process/"
    )


def test_a_frame_too_large_for_a_record_is_refused_before_the_ring():
    ring = FrameRing.create(4, records.SLOT_BYTES)
    try:
        with pytest.raises(records.TooLarge):
            records.put_markers(ring, 0, _tracked(np.random.default_rng(1), 0.0, records.MAX_MARKERS + 1))
        assert ring.written == 0
    finally:
        ring.close()


def test_a_stopped_writer_process_never_stalls_the_hand_over_and_its_loss_is_seen():
    rng = np.random.default_rng(2)
    subscriber_session = open_session()
    publisher = ZenohProcessPublisher("stalled", CAMERAS, "link1", clock=SimClock())
    pid = publisher.process.pid
    frames = [_tracked(rng, 0.01 * k, 4) for k in range(10)]
    handed = RING_SLOTS + 1000
    try:
        subscription = Subscription(subscriber_session, "wiithrow/stalled/markers")
        assert publisher.wait_for_subscribers(20.0)
        os.kill(pid, signal.SIGSTOP)
        for k in range(handed):  # nothing reads: the ring comes round, nothing waits
            assert publisher.publish_markers(frames[k % 10]) == k
        os.kill(pid, signal.SIGCONT)
        assert publisher.flush(30.0)
        lost = handed - (RING_SLOTS - 1)  # it read the newest ring-full (but the slot being rewritten)
        assert publisher.records_dropped == lost and publisher.failure is None
        got = _drain(subscription, RING_SLOTS - 1)
        assert [s.decode()["seq"] for s in got] == list(range(lost, handed))  # the gap, in seq
        assert f"({lost} frames dropped: the writer process was behind)" in publisher.summary()
    finally:
        os.kill(pid, signal.SIGCONT)
        publisher.close()
        subscriber_session.close()
    assert _gone(pid, END_WITHIN_S)


def _simulated_rig():
    from wiithrow.app.rig.moving_markers import crossing_paths
    from wiithrow.app.rig.simulated import simulated_drivers
    from wiithrow.app.rig.stream import RigStream
    from wiithrow.app.settings import Settings
    from wiithrow.app.worlds import nominal_cameras
    from wiithrow.clock import SimClock

    cameras = nominal_cameras(Settings().with_cameras(2).rig)
    clock = SimClock()
    drivers, _ = simulated_drivers(cameras, lambda t: crossing_paths(t, 2.0), clock, np.random.default_rng(3))
    return RigStream(drivers, np.stack([c.P for c in cameras])), clock


def test_a_killed_writer_process_is_one_line_and_the_tracking_goes_on():
    told: list[str] = []
    rig, clock = _simulated_rig()
    publisher = ZenohProcessPublisher("killed", ["cam0", "cam1"], "link1", clock=clock, on_failure=told.append)
    try:
        publisher.follow(rig)  # as `--publish` follows: on the rig's thread
        rig.connect()
        os.kill(publisher.process.pid, signal.SIGKILL)
        end = time.monotonic() + 10.0
        while not told and time.monotonic() < end:
            time.sleep(0.02)
        assert len(told) == 1 and "\n" not in told[0]
        assert told[0].startswith("the Zenoh writer process ended (exit status -9)")
        while clock.now() < 3.0:  # 3 s of tracking after the kill
            rig.poll()
            clock.sleep(0.001)
        assert publisher.markers_sent >= 290 and sum(publisher.dots_sent) >= 590  # every frame handed over
        assert len(rig.tracked_since(0.0)) > 0
        assert not publisher.flush(0.2)  # nobody reads any more: said, not waited for
        assert "; publishing stopped: the Zenoh writer process ended (exit status -9)" in publisher.summary()
    finally:
        publisher.close()
        rig.close()


def test_a_session_the_writer_process_cannot_open_is_one_line_and_exit_2(tmp_path, capsys):
    with socket.socket() as busy:
        busy.bind(("127.0.0.1", 0))
        busy.listen()
        listen_cfg, _ = loopback_configs(tmp_path, busy.getsockname()[1])
        assert main(["track", "--sim", "--publish", "--zenoh-config", str(listen_cfg), "--duration", "1"]) == 2
    err = capsys.readouterr().err.splitlines()
    assert err[0].startswith("world: simulated rig"), err  # what it built, then the error
    (error,) = after_opening(err)
    assert error.startswith("wiithrow track: Zenoh: the writer process did not start: cannot open a Zenoh session")
    assert "Address already in use" in error and ".rs:" not in error


def test_the_writer_process_ends_when_its_owner_ends_without_closing_it():
    code = (
        "import os\n"
        "from wiithrow.app.channels.zenoh_sink import ZenohProcessPublisher\n"
        "from wiithrow.clock import SimClock\n"
        "p = ZenohProcessPublisher('orphan', ['cam0', 'cam1'], 'link1', clock=SimClock())\n"
        "print(p.process.pid, flush=True)\n"
        "os._exit(0)\n"
    )
    owner = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert owner.returncode == 0, owner.stderr
    assert _gone(int(owner.stdout.strip()), END_WITHIN_S)  # its stdin closed with its owner: no orphan


def test_the_answers_come_back_field_by_field():
    ring = FrameRing.create(4, records.BACK_SLOT_BYTES)
    reader = FrameRing.open(ring.name, 4, records.BACK_SLOT_BYTES, ring.wake_fd, other_process=False)
    try:
        records.put_sender(ring, "f" * records.ID_CHARS, "0123456789abcdef")
        records.put_put(ring, 12.345, 987654321)
        sender, put = (records.unpack(r) for r in reader.read())
        assert sender == records.SenderRecord("f" * records.ID_CHARS, "0123456789abcdef")
        assert put == records.Put(12.345, 987654321)
    finally:
        reader.close()
        ring.close()


def test_the_child_formats_a_record_to_the_very_text_the_in_process_publisher_puts():
    """`unpack_marker_rows` (the writer's path, no numpy) gives the same JSON text, byte for byte, as the
    tracked frame itself: NaN velocities, sub-micrometre rounding, 0 to MAX_MARKERS markers."""
    rng = np.random.default_rng(3)
    ring = FrameRing.create(8, records.VECTOR_SLOT_BYTES)
    reader = FrameRing.open(ring.name, 8, records.VECTOR_SLOT_BYTES, ring.wake_fd, other_process=False)
    sender = Sender("f00d", "0123456789abcdef")
    try:
        for seq, n in enumerate([0, 1, 4, records.MAX_MARKERS]):
            frame = _tracked(rng, 0.01 * seq + 0.004, n)
            records.put_markers(ring, 100 + seq, frame, vectors=True)
            (record,) = reader.read()
            got_seq, rows = records.unpack_marker_rows(record)
            assert got_seq == 100 + seq
            assert markers_message("r", got_seq, rows, "link1", 5.0, sender=sender) == markers_message(
                "r", 100 + seq, frame, "link1", 5.0, sender=sender
            )
        records.put_dots(ring, 0, 7, _camera_frame(rng, 0.0))
        (dots,) = reader.read()
        with pytest.raises(ValueError, match="not markers"):
            records.unpack_marker_rows(dots)
    finally:
        reader.close()
        ring.close()
