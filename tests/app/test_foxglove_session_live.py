"""Foxglove live for a session (issue 24): a client of the Foxglove WebSocket protocol (written from
its spec, foxglove/ws-protocol docs/spec.md, as test_foxglove_live's) subscribes to every channel
a simulated session's live server advertises, while a `SessionRecorder` records the same run;
the client receives the markers, the arm's joints, a throw and its trajectory, on channels of the
recording's schemas, and every message it received that the file holds at the same log time is
the file's, byte for byte: from the writer process (`FoxgloveSessionProcessLive`, what the CLI
runs), and in-process (`FoxgloveSessionLive`) but for the arm's samples (its relay's thread reads
the arm later than the frame it stamps them with: the joints differ). A writer process that dies is
one line, and the session throws on."""

from __future__ import annotations

import json
import os
import signal
import struct
import threading
import time
from collections import defaultdict

import pytest
from mcap.reader import make_reader
from websockets.sync.client import connect

from tests.helpers.sim_fixtures import target_at
from wiithrow.app.channels.wall_time import wall_time
from wiithrow.app.foxglove.live import FoxgloveSessionLive
from wiithrow.app.foxglove.session_process_live import FoxgloveSessionProcessLive
from wiithrow.app.recording import channels as ch
from wiithrow.app.recording.session import SessionRecorder
from wiithrow.app.session import simulated_session
from wiithrow.app.worlds.simulated import pump

SESSION_TOPICS = {ch.MARKERS, ch.JOINTS, ch.THROWS, ch.TRAJECTORY, ch.TF, ch.TF_STATIC, ch.ROBOT_DESCRIPTION}


class _Client:
    """A Foxglove client subscribed to every channel as it is advertised; what it received, by
    topic: (log time, payload bytes)."""

    def __init__(self, port: int) -> None:
        self.ws = connect(f"ws://127.0.0.1:{port}", subprotocols=["foxglove.sdk.v1"])
        assert json.loads(self.ws.recv(timeout=10))["op"] == "serverInfo"
        self.channels: dict[str, dict] = {}
        self._topic_of: dict[int, str] = {}
        self.received: dict[str, list[tuple[int, bytes]]] = defaultdict(list)
        self._lock = threading.Lock()
        self._thread = threading.Thread(target=self._read, daemon=True)
        self._thread.start()

    def _read(self) -> None:
        try:
            while True:
                data = self.ws.recv()
                if isinstance(data, str):
                    message = json.loads(data)
                    if message["op"] == "advertise":
                        subscriptions = []
                        for channel in message["channels"]:
                            self.channels[channel["topic"]] = channel
                            self._topic_of[channel["id"]] = channel["topic"]
                            subscriptions.append({"id": channel["id"], "channelId": channel["id"]})
                        self.ws.send(json.dumps({"op": "subscribe", "subscriptions": subscriptions}))
                elif data[0] == 0x01:  # Message Data: subscription id (= the channel's), log time, payload
                    subscription, log_time = struct.unpack_from("<IQ", data, 1)
                    with self._lock:
                        self.received[self._topic_of[subscription]].append((log_time, bytes(data[13:])))
        except Exception:  # closed
            return

    def count(self, topic: str) -> int:
        with self._lock:
            return len(self.received[topic])

    def wait_for(self, topic: str, n: int = 1, timeout_s: float = 20.0) -> bool:
        end = time.monotonic() + timeout_s
        while self.count(topic) < n:
            if time.monotonic() > end:
                return False
            time.sleep(0.01)
        return True

    def close(self) -> None:
        self.ws.close()
        self._thread.join(timeout=5.0)


def _recorded(path) -> tuple[dict[str, tuple[str, bytes]], dict[tuple[str, int], list[bytes]]]:
    """The file's schema (name, data) per topic, and its messages per (topic, log time)."""
    schemas, messages = {}, defaultdict(list)
    with open(path, "rb") as f:
        for schema, channel, message in make_reader(f).iter_messages():
            schemas[channel.topic] = (schema.name, schema.data)
            messages[(channel.topic, message.log_time)].append(message.data)
    return schemas, messages


def _watched(session, client: _Client) -> None:
    """Run the rig until the client receives its markers: from then on the server sends everything."""
    end = time.monotonic() + 20.0
    while client.count(ch.MARKERS) < 5:
        assert time.monotonic() < end, "no markers reached the client within 20 s"
        pump(session.world.clock, session.world.rig, 0.01, step_s=0.001)
        time.sleep(0.005)


@pytest.mark.parametrize(
    "live_class", [FoxgloveSessionLive, FoxgloveSessionProcessLive], ids=["in_process", "writer_process"]
)
def test_a_foxglove_client_gets_the_session_as_its_recording_has_it(live_class, tmp_path):
    session = simulated_session(seed=5, calibration="true", quiet=True)
    live = live_class(session, port=0)
    client = _Client(live.port)
    path = tmp_path / "session.mcap"
    try:
        _watched(session, client)
        recorder = SessionRecorder(session, path)
        began_ns = wall_time(session.world.clock).stamp_ns(session.world.clock.now())
        assert live.arm is not None
        live.arm.restart()  # its arm samples in phase with the recorder's: both from the next frame on
        recorder.begin()
        session.set_target(target_at(1.3, 0.35, 0.1))
        assert session.align().converged
        session.throw(session.plan_preview().id)
        recorder.close()
        indexes = [record.index for record in session.history]
        assert client.wait_for(ch.THROWS) and client.wait_for(ch.TRAJECTORY)
        if isinstance(live, FoxgloveSessionProcessLive):
            assert live.flush(10.0)
        time.sleep(0.5)  # the last messages on their way
    finally:
        client.close()
        live.close()
        session.close()
    schemas, recorded = _recorded(path)
    assert set(client.received) >= SESSION_TOPICS, set(client.received)
    for topic in client.received:  # the recording's schema on every channel the client got messages on
        channel = client.channels[topic]
        assert channel["encoding"] == "json" and channel["schemaEncoding"] == "jsonschema"
        assert (channel["schemaName"], channel["schema"].encode()) == schemas[topic], topic
    late_arm = {ch.JOINTS, ch.TF} if live_class is FoxgloveSessionLive else set()
    same: dict[str, int] = defaultdict(int)
    for topic, got in client.received.items():
        for log_time, payload in got:
            if (topic, log_time) in recorded and topic not in late_arm:
                assert payload in recorded[(topic, log_time)], (topic, log_time, payload[:200])
                same[topic] += 1
    throws = [json.loads(p) for _, p in client.received[ch.THROWS]]
    assert [m["record"]["index"] for m in throws] == indexes and len(indexes) == 1
    assert same[ch.THROWS] == 1 and same[ch.TRAJECTORY] == 1  # the throw and its previewed trajectory
    # the rig's and the arm's (the recorder samples as the live one does, from a phase of its own)
    # every frame's markers and (in the writer process) every arm sample since the recording began
    # (about 390 frames and 160 samples in the run: at least a quarter of them, should some be lost)
    for topic, at_least in {ch.MARKERS: 100, ch.JOINTS: 40}.items():
        if topic in late_arm:
            continue
        since = [log_time for log_time, _ in client.received[topic] if log_time > began_ns]
        assert same[topic] == len(since) >= at_least, (topic, dict(same), len(since))
    if not late_arm:
        assert same[ch.TF] >= same[ch.JOINTS]  # each sample's base -> link1


def test_a_session_writer_process_that_dies_is_one_line_and_the_session_throws_on(capfd):
    session = simulated_session(seed=5, calibration="true", quiet=True)
    live = FoxgloveSessionProcessLive(session, port=0, command="demo")
    try:
        end = time.monotonic() + 10.0
        while live.messages_sent < 1 and time.monotonic() < end:  # the arm's URDF, handed over at the start
            time.sleep(0.02)
        os.kill(live.process.pid, signal.SIGKILL)
        end = time.monotonic() + 10.0
        while live.failure is None and time.monotonic() < end:
            time.sleep(0.02)
        assert live.failure is not None and live.failure.startswith("the Foxglove writer process ended")
        session.set_target(target_at(1.3, 0.35, 0.1))
        assert session.align().converged  # the rig's events go on into a ring nobody reads
        session.throw(session.plan_preview().id)
        assert len(session.history) == 1
        end = time.monotonic() + 10.0
        while live.messages_dropped < 2 and time.monotonic() < end:  # the preview and the throw: nobody to take them
            time.sleep(0.02)
        assert live.messages_dropped == 2
    finally:
        live.close()
        session.close()
    lines = [line for line in capfd.readouterr().err.splitlines() if "Foxglove writer process" in line]
    assert len(lines) == 1 and lines[0].startswith("wiithrow demo: the Foxglove writer process ended"), lines


def test_an_arm_record_comes_back_exactly_and_one_too_large_is_refused():
    import numpy as np

    from wiithrow.app.channels import records
    from wiithrow.app.channels.frame_ring import FrameRing

    rng = np.random.default_rng(3)
    q, dq, T = rng.normal(size=7), rng.normal(size=7), rng.normal(size=(4, 4))
    ring = FrameRing.create(4, records.SLOT_BYTES)
    reader = FrameRing.open(ring.name, 4, records.SLOT_BYTES, ring.wake_fd, other_process=False)
    try:
        records.put_arm(ring, 0.681, q, dq, T)
        (got,) = [records.unpack(r) for r in reader.read()]
        assert isinstance(got, records.Arm) and got.t == 0.681
        assert got.q.tolist() == q.tolist() and got.dq.tolist() == dq.tolist() and got.T.tolist() == T.tolist()
        with pytest.raises(records.TooLarge, match="an arm of 17 joints"):
            records.put_arm(ring, 0.0, np.zeros(17), np.zeros(17), T)
        assert ring.written == 1  # nothing packed
    finally:
        reader.close()
        ring.close()
