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

`--ros2` and `--foxglove` (issue 24: the figures unchanged with them on) attach the publishers as
`track` attaches them, their cost inside the timed loop: the ROS 2 publisher on a loopback domain
(a domain and namespace of its own) as a `RigFollower(thread=False)` put after each report (no subscriber), Foxglove live subscribed
to the rig on a free loopback port (no client); per rig, `ros2_marker_frames` and
`foxglove_messages` count what they sent (present only when attached).
"""

from __future__ import annotations

import os
import time
from collections.abc import Callable
from contextlib import ExitStack
from dataclasses import dataclass, field
from typing import cast

import numpy as np

from wiithrow.app.network.publisher import RigFollower
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
    """The publishers following a rig: what to put after each report, and what each sent."""

    followers: list[RigFollower] = field(default_factory=list)
    counts: dict[str, Callable[[], int]] = field(default_factory=dict)


def attach(stack: ExitStack, rig: TrackingPipeline, *, ros2: bool, foxglove: bool) -> Attached:
    """The publishers asked for, following `rig` until `stack` closes (ROS 2's follower is put
    after each report: `track` puts it after each poll, on the tracking thread)."""
    attached = Attached()
    if foxglove:
        from wiithrow.app.foxglove.live import FoxgloveLive

        live = FoxgloveLive(rig, port=0)
        stack.callback(live.close)
        attached.counts["foxglove_messages"] = live.logged
    if ros2:
        from wiithrow.app.ros2.domain import LOOPBACK_CONFIG, Ros2Domain
        from wiithrow.app.ros2.publisher import Ros2Publisher

        # a domain and namespace of this process's own, as `bench ros2` (no one else's topics)
        domain = Ros2Domain(100 + os.getpid() % 100, LOOPBACK_CONFIG)
        stack.callback(domain.close)
        publisher = Ros2Publisher(domain, rig.camera_names, "link1", namespace=f"/bench_{os.getpid()}")
        publisher.publish_calibration(rig.Ps)
        # the follower needs only what the pipeline has (its lock and subscribe), not a whole source
        follower = RigFollower(publisher, cast(MarkerSource, rig), thread=False)
        follower.start()
        stack.callback(follower.stop)
        attached.followers.append(follower)
        attached.counts["ros2_marker_frames"] = lambda: publisher.markers_sent
    return attached


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
    with ExitStack() as stack:
        attached = attach(stack, rig, ros2=ros2, foxglove=foxglove)
        for c, t, data in reports:
            start = time.perf_counter()
            tracked = rig.process(c, decoders[c].decode([(t, data)]))
            for follower in attached.followers:
                follower.put_pending()
            elapsed = time.perf_counter() - start
            total += elapsed
            if tracked:
                frames += len(tracked)
                markers += sum(len(f) for f in tracked)
                latencies.append(elapsed)
        sent = {name: count() for name, count in attached.counts.items()}
    latencies_ms = 1e3 * np.array(latencies)
    return {
        "reports": len(reports),
        "synced_frames": frames,
        "markers_per_frame": markers / max(frames, 1),
        "frames_per_s": frames / total,
        "p50_ms": float(np.percentile(latencies_ms, 50)),
        "p99_ms": float(np.percentile(latencies_ms, 99)),
        "max_ms": float(latencies_ms.max()),
        **sent,
    }


def run(quick: bool = False, *, ros2: bool = False, foxglove: bool = False) -> dict[str, dict[str, float]]:
    seconds = 5.0 if quick else 60.0
    return {f"remotes_{n}": measure(n, seconds, ros2=ros2, foxglove=foxglove) for n in REMOTES}
