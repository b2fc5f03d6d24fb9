"""Foxglove live (issue 24): a client of the Foxglove WebSocket protocol, written here from its
spec (foxglove/ws-protocol, docs/spec.md) with `websockets`, connects to the live server,
subscribes to `/markers` and decodes every frame the rig tracked meanwhile, equal to it."""

from __future__ import annotations

import json
import struct
import time

import numpy as np
import pytest
from websockets.sync.client import connect

from wiithrow.app.channels.foxglove_sink import FoxgloveProcessLive
from wiithrow.app.channels.json_schemas import SCHEMAS
from wiithrow.app.channels.wall_time import wall_time
from wiithrow.app.foxglove.live import FoxgloveLive
from wiithrow.app.recording import channels as ch
from wiithrow.app.rig.source import newest_t
from wiithrow.clock import SimClock


def _rig():
    from wiithrow.app.rig.moving_markers import crossing_paths
    from wiithrow.app.rig.simulated import simulated_drivers
    from wiithrow.app.rig.stream import RigStream
    from wiithrow.app.settings import Settings
    from wiithrow.app.worlds import nominal_cameras

    cameras = nominal_cameras(Settings().with_cameras(2).rig)
    clock = SimClock()
    drivers, _ = simulated_drivers(cameras, lambda t: crossing_paths(t, 2.0), clock, np.random.default_rng(0))
    return RigStream(drivers, np.stack([c.P for c in cameras])), clock


def _advertised(ws, topics: set[str]) -> dict[str, dict]:
    channels: dict[str, dict] = {}
    while not topics <= set(channels):
        message = json.loads(ws.recv(timeout=10))
        if message["op"] == "advertise":
            channels.update({c["topic"]: c for c in message["channels"]})
    return channels


@pytest.mark.parametrize("live_class", [FoxgloveLive, FoxgloveProcessLive], ids=["in_process", "writer_process"])
def test_a_foxglove_client_subscribes_to_the_markers_and_decodes_what_was_tracked(live_class):
    rig, clock = _rig()
    live = live_class(rig, port=0)
    tracked = []
    try:
        rig.connect()
        with connect(f"ws://127.0.0.1:{live.port}", subprotocols=["foxglove.sdk.v1"]) as ws:
            assert ws.subprotocol == "foxglove.sdk.v1"
            info = json.loads(ws.recv(timeout=10))
            assert info["op"] == "serverInfo"
            clock.sleep(0.05)
            rig.poll()  # the first frames: the channels exist once something was logged on them
            channels = _advertised(ws, {ch.MARKERS, ch.MARKERS_SCENE, ch.TF_STATIC})
            markers = channels[ch.MARKERS]
            assert markers["encoding"] == "json" and markers["schemaName"] == "wiithrow.Markers"
            assert json.loads(markers["schema"]) == SCHEMAS["wiithrow.Markers"]  # the recording's schema
            assert channels[ch.MARKERS_SCENE]["schemaName"] == "foxglove.SceneUpdate"
            assert channels[ch.TF_STATIC]["schemaName"] == "foxglove.FrameTransforms"
            ws.send(json.dumps({"op": "subscribe", "subscriptions": [{"id": 7, "channelId": markers["id"]}]}))
            time.sleep(0.5)  # the server takes the subscription in
            since = newest_t(rig)
            for _ in range(50):  # 0.5 s of the rig at 100 Hz
                clock.sleep(0.01)
                rig.poll()
            tracked = rig.tracked_since(since)
            got = []
            while len(got) < len(tracked):
                data = ws.recv(timeout=10)
                if isinstance(data, bytes) and data[0] == 0x01:  # Message Data
                    subscription, log_time = struct.unpack_from("<IQ", data, 1)
                    assert subscription == 7
                    got.append((log_time, json.loads(data[13:])))
    finally:
        live.close()
        rig.close()
    assert len(tracked) >= 45
    got = [m for m in got if m[1]["t"] > since][: len(tracked)]
    assert len(got) == len(tracked)
    for (log_time, message), frame in zip(got, tracked):
        assert log_time == wall_time(clock).stamp_ns(frame.t)  # the rig's clock in Unix time
        assert message["t"] == frame.t and message["frame_id"] == "link1"
        assert message["ids"] == frame.ids.tolist()
        assert message["positions"] == frame.position.tolist()
        assert message["visible"] == frame.visible.tolist()
        assert message["views"] == frame.n_views.tolist()


def test_beyond_loopback_is_refused_in_one_line_unless_the_risk_is_accepted():
    import pytest

    from wiithrow.app.errors import AppError

    rig, _ = _rig()
    with pytest.raises(AppError, match=r"--foxglove-host 0\.0\.0\.0: .*cannot check a token.*SSH tunnel") as refused:
        FoxgloveLive(rig, port=0, host="0.0.0.0")
    assert "\n" not in str(refused.value)
    live = FoxgloveLive(rig, port=0, host="0.0.0.0", insecure_network=True)  # the operator accepted it
    try:
        assert live.url() == f"ws://0.0.0.0:{live.port}"
        with connect(f"ws://127.0.0.1:{live.port}", subprotocols=["foxglove.sdk.v1"]) as ws:
            info = json.loads(ws.recv(timeout=10))
            assert info["op"] == "serverInfo"
            assert info["capabilities"] == []  # a client can look, not act: no publish, services, parameters
    finally:
        live.close()


def test_with_no_client_the_rig_events_are_not_even_queued_and_the_channels_are_advertised_at_once():
    rig, clock = _rig()
    live = FoxgloveLive(rig, port=0)
    try:
        rig.connect()
        for _ in range(20):
            clock.sleep(0.01)
            rig.poll()
        assert live.unwatched() > 20 and live.logged() == 0 and live.dropped() == 0
        with connect(f"ws://127.0.0.1:{live.port}", subprotocols=["foxglove.sdk.v1"]) as ws:
            assert json.loads(ws.recv(timeout=10))["op"] == "serverInfo"
            # no poll since the client came: the rig's channels are there all the same
            channels = _advertised(ws, {ch.MARKERS, ch.MARKERS_SCENE, ch.TF_STATIC, ch.STEPS, ch.dots_topic(1)})
            assert channels[ch.MARKERS]["schemaName"] == "wiithrow.Markers"
    finally:
        live.close()
        rig.close()


def test_a_full_relay_drops_and_counts_events_and_never_blocks_the_rig():
    import threading

    from wiithrow.app.foxglove import live as fl

    release, handled = threading.Event(), []

    def slow(event):  # a server thread that is behind: it waits on the first event
        handled.append(event)
        release.wait(10.0)

    relay = fl._Relay(slow, lambda: True, thread=True)
    relay.put(0)
    end = time.monotonic() + 10.0
    while not handled and time.monotonic() < end:
        time.sleep(0.001)
    for i in range(1, fl.QUEUE_EVENTS + 6):
        relay.put(i)  # returns at once: the queue is never waited for
    assert relay.dropped == 5
    release.set()
    relay.stop()
    assert handled == list(range(fl.QUEUE_EVENTS + 1))  # the queued ones, in order


def test_the_foxglove_writer_process_says_in_one_line_why_it_cannot_serve_and_when_it_ends():
    import os
    import signal
    import socket

    from wiithrow.app.errors import AppError

    rig, _ = _rig()
    taken = socket.socket()
    taken.bind(("127.0.0.1", 0))
    taken.listen()
    try:
        with pytest.raises(AppError) as refused:
            FoxgloveProcessLive(rig, port=taken.getsockname()[1])
        assert "\n" not in str(refused.value) and "cannot serve on 127.0.0.1" in str(refused.value)
    finally:
        taken.close()
    live = FoxgloveProcessLive(rig, port=0)
    try:
        os.kill(live.process.pid, signal.SIGKILL)
        end = time.monotonic() + 10.0
        while live.failure is None and time.monotonic() < end:
            time.sleep(0.02)
        assert live.failure is not None and live.failure.startswith("the Foxglove writer process ended")
        rig.connect()
        rig.poll()  # the rig goes on: its events are packed into a ring nobody reads
    finally:
        live.close()
        rig.close()
