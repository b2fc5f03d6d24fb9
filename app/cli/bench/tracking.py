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
"""

from __future__ import annotations

import time
from typing import Any

import numpy as np

from wiithrow.app.rig.moving_markers import crossing_paths
from wiithrow.app.rig.pipeline import TrackingPipeline
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


def measure(remotes: int, seconds: float) -> dict[str, float]:
    """The figures of one rig (see the module docstring)."""
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
    for c, t, data in reports:
        start = time.perf_counter()
        tracked = rig.process(c, decoders[c].decode([(t, data)]))
        elapsed = time.perf_counter() - start
        total += elapsed
        if tracked:
            frames += len(tracked)
            markers += sum(len(f) for f in tracked)
            latencies.append(elapsed)
    latencies_ms = 1e3 * np.array(latencies)
    return {
        "reports": len(reports),
        "synced_frames": frames,
        "markers_per_frame": markers / max(frames, 1),
        "frames_per_s": frames / total,
        "p50_ms": float(np.percentile(latencies_ms, 50)),
        "p99_ms": float(np.percentile(latencies_ms, 99)),
        "max_ms": float(latencies_ms.max()),
    }


def run(quick: bool = False) -> dict[str, Any]:
    seconds = 5.0 if quick else 60.0
    return {f"remotes_{n}": measure(n, seconds) for n in REMOTES}
