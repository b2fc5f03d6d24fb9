"""The garbage collector while a session serves: `frozen_heap()` and `CollectionPauses`.

CPython's cyclic garbage collector runs in whichever thread allocated last and holds the
interpreter while it runs, so every thread of the process (the rig's loop, a throw's, the
dashboard's) waits for it. A full pass (generation 2) walks every container the collector tracks,
and what a session builds at start-up (the modules, numba's, Pinocchio's, MuJoCo's and viser's
objects, the world, the calibration: about 146,000 containers in `bench latency`'s session) lives
until the process ends, yet each full pass walks it again. Measured with `gc.callbacks` in 45-s
runs of `bench latency`'s attached configuration: full passes of 80-140 ms, one every 30-40 s,
a stall of the whole process at any moment: mid-throw, a release command 0.1 s late.

`frozen_heap()`: `gc.collect()` then `gc.freeze()` (the start-up's survivors move to the permanent
generation, which no pass walks) while a session serves, and `gc.unfreeze()` when it ends (a
process that goes on, a test, gets them back). What it costs: a cycle of start-up objects that
becomes garbage while serving (an old calibration's objects) is freed only at the end. Python's
documentation gives `gc.freeze` for forked servers; the latency use is the same idea: objects that
never die are not worth walking.

`CollectionPauses`: each collection's generation and duration (`gc.callbacks`) over a measured
window (`begin`, `end`): count, p50, max and total ms per generation (`bench latency`'s
`gc_pauses`).
"""

from __future__ import annotations

import gc
import time
from collections.abc import Iterator
from contextlib import contextmanager
from typing import Any


@contextmanager
def frozen_heap() -> Iterator[int]:
    """Freeze what survives a full collection now; unfreeze on exit. Yields how many objects froze."""
    gc.collect()
    gc.freeze()
    try:
        yield gc.get_freeze_count()
    finally:
        gc.unfreeze()


class CollectionPauses:
    """Every collection between `begin` and `end` (module docstring)."""

    def __init__(self) -> None:
        self._started: float | None = None
        self._pauses: list[tuple[int, float]] = []  # (generation, seconds)
        self._recording = False

    def _callback(self, phase: str, info: dict[str, Any]) -> None:
        now = time.perf_counter()
        if phase == "start":
            self._started = now
        elif self._started is not None:
            if self._recording:
                self._pauses.append((int(info["generation"]), now - self._started))
            self._started = None

    def begin(self) -> None:
        self._pauses.clear()
        self._recording = True
        if self._callback not in gc.callbacks:
            gc.callbacks.append(self._callback)

    def end(self) -> dict[str, dict[str, float]]:
        """Per generation ("0", "1", "2"): count, p50_ms, max_ms, total_ms; then stop listening."""
        self._recording = False
        if self._callback in gc.callbacks:
            gc.callbacks.remove(self._callback)
        out: dict[str, dict[str, float]] = {}
        for generation in (0, 1, 2):
            ms = sorted(1e3 * s for g, s in self._pauses if g == generation)
            out[str(generation)] = {
                "count": len(ms),
                "p50_ms": ms[len(ms) // 2] if ms else 0.0,
                "max_ms": ms[-1] if ms else 0.0,
                "total_ms": sum(ms),
            }
        return out
