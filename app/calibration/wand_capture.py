"""Capturing a wand: the rig's synchronised frames for a while, and the coverage as it grows.

`capture_wand(rig, clock, seconds)` lets `seconds` pass on the clock (`wiithrow.app.rig.waiting.pump`,
reading the remotes every millisecond), collects every synchronised frame the rig emits meanwhile
(`MarkerSource.synced_since`: calibrated or not, the dots of every camera at the reference camera's
frame times) and turns them into `WandObservations` (`wiithrow.vision.wand.observations.from_dots`:
two dots are the wand's ends, one dot one end, more nothing). About every half second it reports
progress: the fraction of the time done, how many frames each camera saw both LEDs in, and each
camera's coverage so far (`wiithrow.vision.wand.quality.coverage_map`), so that whoever waves can
see where the wand has not been yet. Nothing here knows whether the remotes are simulated.

Why every millisecond: the driver dates a report by when it was read (`wiithrow.vision.wiimote.frames`:
the newest report of a batch left the remote "just now"), so reading every 10 ms dates each remote's
reports up to 10 ms late, by a delay fixed by its phase: the synchroniser then pairs dots from
different instants, and a wand moving at 1 m/s is mm off. Measured in simulation (two remotes, 10 s):
reprojection RMS 3.5 px and a test error 1.8 times the robot calibration's when read every 10 ms.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from wiithrow.app.errors import AppError
from wiithrow.app.rig.source import MarkerSource
from wiithrow.app.rig.waiting import Cancel, pump
from wiithrow.clock import Clock
from wiithrow.vision.camera import IMAGE_HEIGHT, IMAGE_WIDTH
from wiithrow.vision.wand.observations import WandObservations, both_ends_seen, from_dots
from wiithrow.vision.wand.quality import MIN_DOTS_PER_CELL, coverage_map

#: How often (s of the clock) the capture reports its progress.
REPORT_EVERY_S = 0.5


@dataclass(frozen=True)
class CaptureProgress:
    """The recording so far: `done` (0..1 of the time), `frames` recorded, frames in which each
    camera saw both LEDs (C,), and each camera's coverage map (C, rows, cols) and fraction visited."""

    done: float
    frames: int
    both: NDArray[np.int64]
    coverage: NDArray[np.int64]

    @property
    def coverage_fraction(self) -> NDArray[np.float64]:
        visited: NDArray[np.float64] = (self.coverage >= MIN_DOTS_PER_CELL).reshape(len(self.coverage), -1).mean(axis=1)
        return visited


Progress = Callable[[CaptureProgress], None]


def capture_wand(
    rig: MarkerSource,
    clock: Clock,
    seconds: float,
    *,
    progress: Progress | None = None,
    cancel: Cancel = None,
    step_s: float = 0.001,
) -> WandObservations:
    """Record the wand for `seconds` (see the module docstring). The remotes must be connected;
    raises `Cancelled` when `cancel` fires, AppError when no frame came."""
    if seconds <= 0:
        raise AppError(f"a wand capture needs a positive duration, got {seconds} s")
    start = clock.now()
    times: list[float] = []
    dots: list[NDArray[np.float64]] = []
    C = len(rig.camera_names)
    coverage = np.zeros((C, -(-IMAGE_HEIGHT // 128), -(-IMAGE_WIDTH // 128)), dtype=np.int64)
    both = np.zeros(C, dtype=np.int64)
    last = [start, start]  # newest frame kept, last report

    def report(done: float) -> None:
        if progress is not None:
            progress(CaptureProgress(done, len(times), both.copy(), coverage.copy()))

    def collect() -> None:
        fresh = rig.synced_since(last[0])
        if fresh:
            last[0] = fresh[-1].t
            times.extend(f.t for f in fresh)
            dots.extend(f.dots for f in fresh)
            part = from_dots([f.t for f in fresh], [f.dots for f in fresh])
            both[:] += both_ends_seen(part.pixels).sum(axis=1)
            for c in range(C):
                coverage[c] += coverage_map(part.pixels[c], part.image_size)
        now = clock.now()
        if now - last[1] >= REPORT_EVERY_S:
            last[1] = now
            report(min((now - start) / seconds, 1.0))

    pump(clock, rig, seconds, step_s=step_s, on_read=collect, cancel=cancel)
    collect()
    report(1.0)
    if not times:
        raise AppError(
            f"the remotes sent no frame in {seconds:g} s of recording: check that they are connected and streaming"
        )
    return from_dots(np.asarray(times), np.asarray(dots))
