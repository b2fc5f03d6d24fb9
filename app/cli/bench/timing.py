"""Timing helpers shared by the benchmarks."""

from __future__ import annotations

import os
import time
from collections.abc import Callable, Sequence

import numpy as np


def best_of(function: Callable[[], object], repeats: int = 5) -> float:
    """The fastest of `repeats` runs of `function`, in seconds (the least disturbed measurement)."""
    best = float("inf")
    for _ in range(repeats):
        start = time.perf_counter()
        function()
        best = min(best, time.perf_counter() - start)
    return best


def delivery_figures(
    latencies_ms: Sequence[float], seqs: Sequence[int], published: int, duration_s: float
) -> dict[str, float | int]:
    """What a publishing benchmark (`publish`, `ros2`) reports of the frames a subscriber in
    another process received: how many, lost (published but never received, by sequence number),
    out of order, and the latency's p50 / p99 / max (ms), with the machine's load (others' work
    stretches the tail)."""
    lat = np.asarray(latencies_ms, dtype=float)
    return {
        "frames_published": published,
        "frames_received": len(seqs),
        "lost_frames": published - len(set(seqs)),
        "out_of_order": int(np.sum(np.diff(seqs) <= 0)) if len(seqs) > 1 else 0,
        "duration_s": round(duration_s, 3),
        "p50_ms": float(np.percentile(lat, 50)),
        "p99_ms": float(np.percentile(lat, 99)),
        "max_ms": float(lat.max()),
        "load_average_1min": os.getloadavg()[0],
    }
