"""`wiithrow bench calibration`: calibrating a rig from many points, with leave-one-out.

Two simulated Wiimotes (sigma 0.5 px, integer pixels) and N known points in their common view;
for each N (300, 2,000 and 100,000; `--quick`: 300 and 2,000) the time and the peak memory of
`calibrate_rig` with the default method (refined: the normalised DLT, Levenberg-Marquardt, the
leave-one-out 3D error of every point), and the same for the linear `normalized` method. Goal:
100,000 points in under 10 s and 200 MB. Time is measured in one run (wall clock `seconds`, and
`cpu_seconds` of this process: on a machine shared with other work the wall clock says more about
the others), memory in a second one under tracemalloc (which counts numpy's buffers and slows
Python code down); the peak is what the calibration allocates beyond its inputs.
"""

from __future__ import annotations

import time
import tracemalloc

import numpy as np

from wiithrow.app.calibration.points import calibrate_rig
from wiithrow.vision.rig import observe_all, points_in_common_view, stereo_rig

SIZES = (300, 2_000, 100_000)
QUICK_SIZES = (300, 2_000)
GOAL = {"points": 100_000, "seconds": 10.0, "peak_mb": 200.0}


def run(quick: bool = False) -> dict:
    cameras = stereo_rig()
    rng = np.random.default_rng(0)
    result: dict[str, object] = {"goal": GOAL}
    for n in QUICK_SIZES if quick else SIZES:
        world = points_in_common_view(cameras, n, rng)
        image = observe_all(cameras, world, rng)
        for method in ("refined", "normalized"):
            start, cpu = time.perf_counter(), time.process_time()
            fit = calibrate_rig(world, image, method=method)
            seconds, cpu = time.perf_counter() - start, time.process_time() - cpu
            tracemalloc.start()
            try:
                calibrate_rig(world, image, method=method)
                peak = tracemalloc.get_traced_memory()[1]
            finally:
                tracemalloc.stop()
            result[f"{method}_{n}"] = {
                "points": n,
                "seconds": seconds,
                "cpu_seconds": cpu,
                "peak_mb": peak / 1e6,
                "loo_mean_mm": 1e3 * fit.loo.mean,
                "loo_tested": fit.loo.tested,
                "rms_px": [c.rms_px for c in fit.calibration.cameras],
            }
    return result
