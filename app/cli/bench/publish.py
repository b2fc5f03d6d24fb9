"""`wiithrow bench publish`: loopback latency from a tracked frame to a subscriber in another process.

The rig of `bench tracking` (two remotes, four markers on crossing paths, recorded report bytes)
is replayed at its real pace, 100 Hz; each tracked frame is published over Zenoh
(`RigPublisher`, stamped with the Unix time it came out of the tracker) the moment it comes out.
A `wiithrow listen` in a child process, connected over TCP on 127.0.0.1 with multicast scouting
off, stamps each sample as it arrives (Zenoh's callback). Latency = arrival - tracked, both on
this machine's clock; it includes encoding the JSON, Zenoh both ways and the child's callback,
not the child's printing.

Figures: `p50_ms`, `p99_ms`, `max_ms` (goal: p99 <= 2 ms), `frames_published`,
`frames_received`, `lost_frames` (published and never received: goal 0), `out_of_order`,
`duration_s` (60 s, 3 s with --quick), `put_p99_ms` (the publisher's part: encoding, signing and
Zenoh's put, until it returns), `payload_bytes` (mean), `check_p99_us` (what a `serve
--markers-from` adds before it adopts a frame: the checks of `wiithrow.app.network.marker_checks`,
payload, volume, source pin and freshness, timed per frame received, in this process after the
run), `sign_p50_us` / `sign_p99_us` and `verify_p50_us` / `verify_p99_us` (the frame's signature
with this user's secret, `wiithrow.app.network.frame_auth`: made by the publisher, checked by the
receiver with its replay memory, timed per frame received on its payload, after the run), `machine_wake` (how late the machine woke a thread over the replay's seconds: `wake_probe`,
the floor under the p99), `load_average_1min` (the machine's load at the end: on a busy machine
the scheduler, not Zenoh, makes the tail).
"""

from __future__ import annotations

import json
import os
import socket
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

import numpy as np

from wiithrow.app.channels.zenoh_sink import RigPublisher
from wiithrow.app.cli.bench.timing import delivery_figures
from wiithrow.app.cli.bench.tracking import decoders_and_pipeline, recorded_reports
from wiithrow.app.cli.bench.wake_probe import WakeProbe
from wiithrow.app.errors import AppError
from wiithrow.app.network.frame_auth import FrameVerifier
from wiithrow.app.network.marker_checks import (
    Freshness,
    MarkerVolume,
    check_identity,
    check_markers_message,
)
from wiithrow.app.network.messages import markers_key
from wiithrow.app.network.source_pin import SourcePin
from wiithrow.app.network.zenoh_session import open_session
from wiithrow.clock import SimClock

RIG = "bench"
GOAL_P99_MS = 2.0


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def loopback_configs(folder: Path, port: int) -> tuple[Path, Path]:
    """Two Zenoh configurations: one listens on tcp/127.0.0.1:port, one connects to it (and listens
    on nothing: a peer's default would be every interface); no scouting."""
    common = {"mode": "peer", "scouting": {"multicast": {"enabled": False}}}
    listen = folder / "listen.json5"
    connect = folder / "connect.json5"
    listen.write_text(json.dumps({**common, "listen": {"endpoints": [f"tcp/127.0.0.1:{port}"]}}))
    connect.write_text(
        json.dumps({**common, "listen": {"endpoints": []}, "connect": {"endpoints": [f"tcp/127.0.0.1:{port}"]}})
    )
    return listen, connect


def run(quick: bool = False) -> dict[str, Any]:
    seconds = 3.0 if quick else 60.0
    reports, Ps = recorded_reports(seconds, np.random.default_rng(0), 2)
    clock = SimClock()
    decoders, counting = decoders_and_pipeline(Ps, clock)
    # The frames the replay will track: the child is told how many to wait for.
    expected = sum(len(counting.process(c, decoders[c].decode([(t, data)]))) for c, t, data in reports)
    with tempfile.TemporaryDirectory(prefix="wiithrow-bench-publish-") as folder:
        listen_cfg, connect_cfg = loopback_configs(Path(folder), free_port())
        zenoh_session = open_session(listen_cfg)
        child = None
        probe = WakeProbe()
        try:
            publisher = RigPublisher(zenoh_session, RIG, counting.camera_names, "link1")
            command = [sys.executable, "-m", "wiithrow.app.cli.main", "listen", markers_key(RIG)]
            command += ["--zenoh-config", str(connect_cfg), "--count", str(expected)]
            command += ["--duration", f"{seconds + 30:g}"]
            env = {**os.environ, "PYTHONUNBUFFERED": "1"}
            child = subprocess.Popen(command, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env)
            if not publisher.wait_for_subscribers(30.0):
                raise AppError("bench publish: the subscriber process did not connect within 30 s")
            decoders, rig = decoders_and_pipeline(Ps, clock)
            put_s = []
            probe.begin()
            start = time.perf_counter()
            for c, t, data in reports:
                delay = start + t - time.perf_counter()
                if delay > 0:
                    time.sleep(delay)
                for frame in rig.process(c, decoders[c].decode([(t, data)])):
                    sent = time.time()
                    publisher.publish_markers(frame, sent=sent)
                    put_s.append(time.time() - sent)
            duration = time.perf_counter() - start
            machine_wake = probe.end()
            out, err = child.communicate(timeout=60.0)
            child = None
        finally:
            probe.close()
            if child is not None:
                child.kill()
                child.wait()
            zenoh_session.close()
    latencies, seqs, payload_bytes, check_s, sign_s, verify_s = [], [], [], [], [], []
    volume, freshness = MarkerVolume(np.asarray(Ps, dtype=float)), Freshness()
    pin = SourcePin(publisher.sender.source)  # as `serve --markers-source` names it
    key, verifier = markers_key(RIG), FrameVerifier.for_this_user()
    for line in out.splitlines():
        sample = json.loads(line)
        data = json.dumps(sample["payload"]).encode()  # the size of what was put
        sign_start = time.perf_counter()
        signature = publisher.signer.sign(key, data)
        sign_s.append(time.perf_counter() - sign_start)
        verify_start = time.perf_counter()
        refused = verifier.check(key, data, signature)
        verify_s.append(time.perf_counter() - verify_start)
        if refused is not None:
            raise AppError(f"bench publish: a signed frame was refused as {refused}")
        check_start = time.perf_counter()
        source, stream = check_identity(sample["payload"], RIG)
        check_markers_message(sample["payload"], volume)
        pin.judge(source, stream, sample["payload"]["seq"], sample["payload"]["t"], sample["received"])
        freshness.judge(sample["payload"]["t"], sample["received"])
        check_s.append(time.perf_counter() - check_start)
        payload = sample["payload"]
        latencies.append(1e3 * (sample["received"] - payload["sent"]))
        seqs.append(payload["seq"])
        payload_bytes.append(len(json.dumps(payload)))
    if not latencies:
        raise AppError(f"bench publish: the subscriber received nothing ({err.strip()[-300:]})")
    return {
        **delivery_figures(latencies, seqs, publisher.markers_sent, duration),
        "put_p99_ms": float(np.percentile(1e3 * np.array(put_s), 99)),
        "goal_p99_ms": GOAL_P99_MS,
        "check_p99_us": float(np.percentile(1e6 * np.array(check_s), 99)),
        "sign_p50_us": float(np.percentile(1e6 * np.array(sign_s), 50)),
        "sign_p99_us": float(np.percentile(1e6 * np.array(sign_s), 99)),
        "verify_p50_us": float(np.percentile(1e6 * np.array(verify_s), 50)),
        "verify_p99_us": float(np.percentile(1e6 * np.array(verify_s), 99)),
        "payload_bytes": float(np.mean(payload_bytes)),
        "machine_wake": machine_wake,
    }
