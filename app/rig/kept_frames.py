"""What a marker source keeps of what it read, and the readers of it: `KeptFrames`.

Both sources that keep frames (the local pipeline, `wiithrow.app.rig.pipeline.TrackingPipeline`,
and another host's markers, `wiithrow.app.network.remote_rig.RemoteRig`) hold each camera's
recent frames (`_history`), the recent tracked frames (`tracked`) and the lock their reads and
writes take (`_lock`); the readers below are theirs alike.
"""

from __future__ import annotations

import threading
from collections import deque
from typing import Protocol, TypeVar

import numpy as np
from numpy.typing import NDArray

from wiithrow.vision.tracked_frame import TrackedFrame
from wiithrow.vision.wiimote.frames import IRFrame


class Timed(Protocol):
    """A kept frame: its time `t` (s, the rig's clock)."""

    @property
    def t(self) -> float: ...


F = TypeVar("F", bound=Timed)


def later_than(frames: deque[F], t: float) -> list[F]:
    """The frames of `frames` later than `t`, oldest first, for frames kept in time order (a rig
    keeps its synchronised and tracked frames so: the synchroniser refuses an older frame, another
    host's are restamped after the last kept): read from the newest back to the first at or
    before `t`, so that a reader asking what came since its last look (a wait polls it every few
    milliseconds) touches the new frames only, not the ten seconds kept."""
    out = []
    for frame in reversed(frames):
        if frame.t <= t:
            break
        out.append(frame)
    out.reverse()
    return out


class KeptFrames:
    """Readers of the kept frames; a subclass sets `_lock`, `_history` and `tracked` in its constructor."""

    _lock: threading.RLock
    _history: list[deque[IRFrame]]  # per camera, oldest first
    tracked: deque[TrackedFrame]  # oldest first

    @property
    def latest(self) -> list[IRFrame | None]:
        """Every camera's most recent frame (None before the first)."""
        with self._lock:
            return [h[-1] if h else None for h in self._history]

    def recent(self, camera: int, count: int) -> list[IRFrame]:
        """Camera `camera`'s last `count` frames, oldest first."""
        with self._lock:
            return list(self._history[camera])[-count:]

    def tracked_since(self, t: float) -> list[TrackedFrame]:
        """The kept tracked frames later than time t, oldest first."""
        with self._lock:
            return later_than(self.tracked, t)

    def latest_tracked(self) -> TrackedFrame | None:
        with self._lock:
            return self.tracked[-1] if self.tracked else None

    def latest_dots(self) -> NDArray[np.float64]:
        """Every camera's most recent dots (C, 4, 2), NaN where none."""
        return np.stack([f.dots if f is not None else np.full((4, 2), np.nan) for f in self.latest])
