"""`wiithrow bench tracking`: from raw report bytes of 2 and of 4 remotes to tracked 3D markers.

The remotes (placed by the settings: `Settings.with_cameras`; random report phases) watch four
markers on crossing paths at up to 2 m/s; their IR reports (extended format, 0x33) are encoded to
bytes beforehand. The timed loop is what runs live for every report: the driver's decoder
(`ReportDecoder.decode`: parse, frame assembly), the frame synchroniser and the tracker
(`TrackingPipeline.process`, the local rig's), on one core.

Figures, per rig (`remotes_2`, `remotes_4`): synchronised frames per second (all reports'
processing time over the tracked frames produced), and p50/p99 latency of a frame: the processing
time of the report that completed it, from its bytes to its tracked markers. Goal: >= 10,000
frames/s (100x the remotes' 100 Hz), p99 <= 0.5 ms.

`--ros2` and `--foxglove` attach the publishers as
`track` attaches them, each a writer process fed through a shared-memory ring (`FrameRing`): the
tracking thread pays for the hand-over only, inside the timed loop; each has someone to publish to
(a publisher skips what nobody reads):
  - ROS 2: `Ros2ProcessPublisher` on a loopback domain (a domain and namespace of its own),
    following the rig as under `track`, and a reader of `markers` in another process (`bench
    ros2`'s child), so every tracked frame is packed and written (CDR) by the writer process (the
    MarkerArray and the dots have no reader: RViz is not open, and the dots are not even handed
    over); `ros2_marker_frames` frames numbered, `ros2_samples_written`,
    `ros2_frames_dropped` (records the writer process lost: the ring came round),
    `ros2_frames_received` by the reader;
  - Foxglove: `FoxgloveProcessLive` on a free loopback port, and a viewer in another process
    (`viewer`: a WebSocket client of the Foxglove protocol subscribed to every channel, reading
    and discarding); `foxglove_messages` logged to it, `foxglove_records_dropped` (the writer
    process was a ring behind).
`cpu_frames_per_s`: the frames over the tracking thread's own CPU time in the loop
(`time.thread_time`: what it spent, not what it waited for the GIL or a core), steadier than
`frames_per_s` on a loaded machine; `load_average_1min` at the end of each rig.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import time
from collections.abc import Callable
from contextlib import ExitStack
from dataclasses import dataclass, field
from typing import Any, cast

import numpy as np

from wiithrow.app.errors import AppError
from wiithrow.app.rig.moving_markers import crossing_paths
from wiithrow.app.rig.pipeline import TrackingPipeline
from wiithrow.app.rig.source import MarkerSource
from wiithrow.app.settings import Settings
from wiithrow.app.worlds import nominal_cameras
from wiithrow.clock import SimClock
from wiithrow.vision.wiimote import input_reports
from wiithrow.vision.wiimote.decoder import ReportDecoder

#: The rigs measured: how many remotes.
REMOTES = (2, 4)


def recorded_reports(
    seconds: float, rng: np.random.Generator, remotes: int = 2
) -> tuple[list[tuple[int, float, bytes]], np.ndarray]:
    """(camera, arrival time, report bytes) of `remotes` remotes in arrival order, and the rig's P."""
    cameras = nominal_cameras(Settings().with_cameras(remotes).rig)
    phases = [0.0] + [float(p) for p in rng.uniform(0.001, 0.009, remotes - 1)]
    reports = []
    for c, camera in enumerate(cameras):
        for k in range(int(seconds * 100)):
            t = phases[c] + 0.01 * k
            X = crossing_paths(t)
            pixels = camera.observe(X, rng)
            sizes = camera.blob_sizes(X)
            dots = {s: (int(u), int(v)) for s, (u, v) in enumerate(pixels) if u == u}
            data = input_reports.encode_ir_report(0x33, dots, sizes={s: int(sizes[s]) for s in dots})
            reports.append((c, t, bytes(data)))
    reports.sort(key=lambda r: (r[1], r[0]))
    return reports, np.stack([c.P for c in cameras])


def decoders_and_pipeline(Ps: np.ndarray, clock: SimClock) -> tuple[list[ReportDecoder], TrackingPipeline]:
    """One report decoder per camera and the pipeline they feed (no transport: recorded bytes)."""
    names = [f"cam{c}" for c in range(len(Ps))]
    return [ReportDecoder(name=name) for name in names], TrackingPipeline(names, clock, Ps)


@dataclass
class Attached:
    """The publishers following a rig, and what each sent."""

    readers: list[Any] = field(default_factory=list)
    flush: list[Callable[[], bool]] = field(default_factory=list)  # before counting: what is queued is written
    counts: dict[str, Callable[[], int]] = field(default_factory=dict)
    after: dict[str, Callable[[], int]] = field(default_factory=dict)  # once the publishers are closed


def _read_markers(stack: ExitStack, domain_id: int, namespace: str) -> Callable[[], int]:
    """A reader of `markers` in another process (`bench ros2`'s child) until `stack` closes; how
    many frames it received (asked once `stack` closed)."""
    command = [sys.executable, "-m", "wiithrow.app.cli.bench.ros2", str(domain_id), namespace]
    child = subprocess.Popen(command, stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    out: list[str] = []

    def end() -> None:
        try:
            out.append(child.communicate("", timeout=30.0)[0])
        except subprocess.TimeoutExpired:
            child.kill()
            child.wait()

    stack.callback(end)
    return lambda: len({json.loads(line)["seq"] for line in "".join(out).splitlines()})


def attach(stack: ExitStack, rig: TrackingPipeline, *, ros2: bool, foxglove: bool) -> Attached:
    """The publishers asked for, following `rig` until `stack` closes, each with a reader (see the
    module docstring: each packs the rig's events on the tracking thread, as under `track`)."""
    attached = Attached()
    if foxglove:
        from wiithrow.app.channels.foxglove_sink import FoxgloveProcessLive

        live = FoxgloveProcessLive(rig, port=0)
        stack.callback(live.close)
        _watch(stack, live.port, len(rig.camera_names))
        attached.flush.append(live.flush)
        attached.after["foxglove_messages"] = live.logged
        attached.after["foxglove_records_dropped"] = live.dropped
    if ros2:
        from wiithrow.app.channels.ros2_sink import Ros2ProcessPublisher

        # a domain and namespace of this process's own, as `bench ros2` (no one else's topics)
        domain_id = 100 + os.getpid() % 100
        namespace = f"/bench_{os.getpid()}"
        publisher = Ros2ProcessPublisher(domain_id, rig.camera_names, "link1", clock=rig.clock, namespace=namespace)
        stack.callback(publisher.close)
        received = _read_markers(stack, domain_id, namespace)
        if not publisher.wait_for_subscribers(30.0):
            raise AppError("bench tracking --ros2: the reader of markers did not match within 30 s")
        time.sleep(0.5)  # discovery both ways (the reader matches the writer too)
        # it follows what the pipeline has (its lock and subscribe), not a whole source
        publisher.follow(cast(MarkerSource, rig))
        attached.flush.append(publisher.flush)
        attached.counts["ros2_marker_frames"] = lambda: publisher.markers_sent
        attached.counts["ros2_samples_written"] = lambda: publisher.samples_written
        attached.counts["ros2_frames_dropped"] = lambda: publisher.records_dropped
        attached.after["ros2_frames_received"] = received
    return attached


def _watch(stack: ExitStack, port: int, cameras: int) -> None:
    """A Foxglove viewer of every channel on `port` (`viewer`, another process) until `stack` closes."""
    command = [sys.executable, "-m", "wiithrow.app.cli.bench.tracking", str(port), str(5 + 2 * cameras)]
    child = subprocess.Popen(command, stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)

    def end() -> None:
        try:
            child.communicate("", timeout=10.0)
        except subprocess.TimeoutExpired:
            child.kill()
            child.wait()

    stack.callback(end)
    assert child.stdout is not None
    line = child.stdout.readline()
    if "subscribed" not in line:
        raise AppError(f"bench tracking --foxglove: the viewer did not subscribe ({line.strip()[-200:]})")
    time.sleep(0.3)  # the server takes the subscriptions in


def viewer(port: int, channels: int) -> None:
    """A Foxglove WebSocket client: subscribe to the first `channels` advertised, say so, then
    read and discard until standard input closes."""
    import json
    import threading

    from websockets.sync.client import connect
    from websockets.typing import Subprotocol

    with connect(f"ws://127.0.0.1:{port}", subprotocols=[Subprotocol("foxglove.sdk.v1")]) as ws:
        advertised: list[int] = []
        while len(advertised) < channels:
            message = ws.recv(timeout=10)
            if isinstance(message, str) and json.loads(message)["op"] == "advertise":
                advertised += [c["id"] for c in json.loads(message)["channels"]]
        subscriptions = [{"id": i, "channelId": c} for i, c in enumerate(advertised)]
        ws.send(json.dumps({"op": "subscribe", "subscriptions": subscriptions}))
        print("subscribed", flush=True)
        done = threading.Event()

        def until_stdin_closes() -> None:
            sys.stdin.read()
            done.set()

        threading.Thread(target=until_stdin_closes, daemon=True).start()
        while not done.is_set():
            try:
                ws.recv(timeout=0.2)
            except TimeoutError:
                pass


def measure(remotes: int, seconds: float, *, ros2: bool = False, foxglove: bool = False) -> dict[str, float]:
    """The figures of one rig (see the module docstring), with the publishers asked for attached."""
    reports, Ps = recorded_reports(seconds, np.random.default_rng(0), remotes)
    clock = SimClock()
    decoders, rig = decoders_and_pipeline(Ps, clock)
    for c, t, data in reports[: 100 * remotes]:  # warm-up: compile the kernels, settle the tracks
        rig.process(c, decoders[c].decode([(t, data)]))
    rig = TrackingPipeline(rig.camera_names, clock, Ps)
    latencies = []
    frames = 0
    markers = 0
    total = 0.0
    cpu = 0.0
    with ExitStack() as stack:
        attached = attach(stack, rig, ros2=ros2, foxglove=foxglove)
        cpu_start = time.thread_time()
        for c, t, data in reports:
            start = time.perf_counter()
            tracked = rig.process(c, decoders[c].decode([(t, data)]))
            elapsed = time.perf_counter() - start
            total += elapsed
            if tracked:
                frames += len(tracked)
                markers += sum(len(f) for f in tracked)
                latencies.append(elapsed)
        cpu = time.thread_time() - cpu_start
        for flush in attached.flush:
            flush()
        sent = {name: count() for name, count in attached.counts.items()}
    sent.update({name: count() for name, count in attached.after.items()})
    latencies_ms = 1e3 * np.array(latencies)
    return {
        "reports": len(reports),
        "synced_frames": frames,
        "markers_per_frame": markers / max(frames, 1),
        "frames_per_s": frames / total,
        "cpu_frames_per_s": frames / cpu,
        "p50_ms": float(np.percentile(latencies_ms, 50)),
        "p99_ms": float(np.percentile(latencies_ms, 99)),
        "max_ms": float(latencies_ms.max()),
        **sent,
        "load_average_1min": os.getloadavg()[0],
    }


def run(quick: bool = False, *, ros2: bool = False, foxglove: bool = False) -> dict[str, dict[str, float]]:
    seconds = 5.0 if quick else 60.0
    return {f"remotes_{n}": measure(n, seconds, ros2=ros2, foxglove=foxglove) for n in REMOTES}


if __name__ == "__main__":
    viewer(int(sys.argv[1]), int(sys.argv[2]))
