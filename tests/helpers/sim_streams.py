"""Camera frame streams for tracking tests: what unsynchronised remotes report for moving markers."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from wiithrow.vision.camera import WiimoteCamera


def frame_events(
    cameras: list[WiimoteCamera],
    positions: Callable[[float], np.ndarray],
    duration: float,
    rng: np.random.Generator,
    *,
    offsets: list[float] | None = None,
    sigma_px: float = 0.5,
    period: float = 0.01,
) -> list[tuple[float, int, np.ndarray]]:
    """(t, camera, dots (4, 2)) in time order; camera c reports at offsets[c] + k * period."""
    offsets = offsets if offsets is not None else [0.0] + list(rng.uniform(0.0, period, len(cameras) - 1))
    events = []
    for c, camera in enumerate(cameras):
        for k in range(int(duration / period)):
            t = offsets[c] + k * period
            events.append((t, c, camera.observe(positions(t), rng, sigma_px=sigma_px)))
    events.sort(key=lambda e: (e[0], e[1]))
    return events
