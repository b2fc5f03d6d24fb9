"""`wiithrow bench record`: what recording a run costs, per synchronised frame, and its size.

Two remotes at 100 Hz watch four markers on crossing paths (the reports of `bench tracking`,
`recorded_reports`); the timed loop decodes each report and tracks it (`ReportDecoder.decode`,
`TrackingPipeline.process`) once without and once with a `Recorder` writing an MCAP file (raw reports,
dots, steps, markers; zstd chunks flushed every second). Figures: `record_ms_per_frame`, the
added time per tracked frame (goal: <= 0.2 ms), and `mb_per_minute`, the file's size per minute
of recording. The file goes to a temporary folder, removed afterwards.
"""

from __future__ import annotations

import tempfile
import time
from pathlib import Path
from typing import Any

import numpy as np

from wiithrow.app.cli.bench.tracking import decoders_and_pipeline, recorded_reports
from wiithrow.app.recording import Recorder
from wiithrow.clock import SimClock

GOAL_MS_PER_FRAME = 0.2


def _track(reports: list[tuple[int, float, bytes]], Ps: np.ndarray, path: Path | None) -> tuple[float, int, int]:
    """Seconds spent, tracked frames, and the file's bytes (0 without recording)."""
    clock = SimClock()
    decoders, rig = decoders_and_pipeline(Ps, clock)
    for c, decoder in enumerate(decoders):  # the raw reports reach the recording as a live rig's do
        decoder.subscribe(rig.reports_listener(c))
    recorder = Recorder(path, clock) if path is not None else None
    if recorder is not None:
        recorder.start(rig)
    frames = 0
    start = time.perf_counter()
    for c, t, data in reports:
        frames += len(rig.process(c, decoders[c].decode([(t, data)])))
    if recorder is not None:
        recorder.close()
    elapsed = time.perf_counter() - start
    return elapsed, frames, path.stat().st_size if path is not None else 0


def run(quick: bool = False) -> dict[str, Any]:
    seconds = 5.0 if quick else 60.0
    reports, Ps = recorded_reports(seconds, np.random.default_rng(0), 2)
    _track(reports[:200], Ps, None)  # warm-up: compile the kernels
    with tempfile.TemporaryDirectory(prefix="wiithrow-bench-record-") as folder:
        path = Path(folder) / "run.mcap"
        _track(reports[:200], Ps, path)
        bare, frames, _ = _track(reports, Ps, None)
        recorded, frames_recorded, size = _track(reports, Ps, path)
    ms_per_frame = 1e3 * (recorded - bare) / max(frames, 1)
    return {
        "remotes": 2,
        "seconds_recorded": seconds,
        "tracked_frames": frames,
        "tracked_frames_recording": frames_recorded,
        "track_ms_per_frame": 1e3 * bare / max(frames, 1),
        "record_ms_per_frame": ms_per_frame,
        "mb_per_minute": size / 1e6 * 60.0 / seconds,
        "goal_ms_per_frame": GOAL_MS_PER_FRAME,
        "meets_goal": ms_per_frame <= GOAL_MS_PER_FRAME,
    }
