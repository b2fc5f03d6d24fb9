"""Bringing unsynchronised cameras to one instant.

Two Wiimotes each report at 100 Hz, but their frames are not aligned: camera b's frame can be up
to 10 ms away from camera a's. A marker moving at 2 m/s travels 10 mm in that time, and
triangulating dots from two different instants puts it in the wrong place (mostly in depth).

`FrameSynchronizer` takes every camera's frames as they arrive (timestamped on arrival) and emits
one synchronised frame per frame of the reference camera (camera 0), at that frame's time t, in
which every other camera's dots are interpolated to t. The Wiimote keeps a blob in the same slot
while it tracks it, so interpolation works slot by slot between the camera's frames just before and
just after t:

    x(t) = x0 + (t - t0) / (t1 - t0) * (x1 - x0)

A slot that is empty on one side, or whose dot jumps by more than `jump_px` (another blob took the
slot), takes the nearer frame's dot if that frame lies within `hold_s` of t, else NaN. A reference
frame waits for the other cameras' next frame (the added latency is at most one frame period); if
a camera falls silent for `max_wait_s`, the frame is emitted with that camera's dots extrapolated
from its last two frames (or NaN when it has none recent).

`method="nearest"` pairs each reference frame with the other cameras' nearest frame in time, with
no interpolation: the naive baseline, kept to measure what interpolation gains.
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass
from typing import Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray

from wiithrow.vision import kernels
from wiithrow.vision.errors import VisionError

SLOTS = 4


@dataclass(frozen=True)
class SyncedFrame:
    """Dots (C, K, 2) of every camera at time `t` (the reference camera's frame time)."""

    t: float
    dots: NDArray[np.float64]


class FrameSynchronizer:
    """Pairs the frames of C unsynchronised cameras by time (see the module docstring)."""

    def __init__(
        self,
        cameras: int,
        *,
        method: Literal["interpolate", "nearest"] = "interpolate",
        slots: int = SLOTS,
        jump_px: float = 60.0,
        hold_s: float = 0.002,
        max_wait_s: float = 0.025,
        history: int = 16,
    ) -> None:
        if cameras < 2:
            raise VisionError(f"synchronising needs at least 2 cameras, got {cameras}")
        if method not in ("interpolate", "nearest"):
            raise VisionError(f"unknown synchronisation method {method!r}: use 'interpolate' or 'nearest'")
        self.cameras = cameras
        self.method = method
        self.slots = slots
        self.jump_px = jump_px
        self.hold_s = hold_s
        self.max_wait_s = max_wait_s
        self._frames: list[deque[tuple[float, NDArray[np.float64]]]] = [deque(maxlen=history) for _ in range(cameras)]
        self._pending: deque[tuple[float, NDArray[np.float64]]] = deque()

    def push(self, camera: int, t: float, dots: ArrayLike) -> list[SyncedFrame]:
        """Add camera `camera`'s frame at time `t` (dots (K, 2), NaN for empty slots); return the
        synchronised frames that became complete, oldest first."""
        x = np.asarray(dots, dtype=float)
        if x.shape != (self.slots, 2):  # fewer slots given: pad with NaN
            given = x.reshape(-1, 2)
            if given.shape[0] > self.slots:
                raise VisionError(f"camera {camera}: {given.shape[0]} dots, more than its {self.slots} slots")
            x = np.full((self.slots, 2), np.nan)
            x[: given.shape[0]] = given
        buffer = self._frames[camera]
        if buffer and t < buffer[-1][0]:
            raise VisionError(f"camera {camera}: frame at t={t:.6f} s is older than the previous one")
        buffer.append((t, x))
        if camera == 0:
            self._pending.append((t, x))
        return self._emit(now=t)

    def flush(self, now: float) -> list[SyncedFrame]:
        """Emit reference frames that have waited `max_wait_s` by time `now` (a silent camera)."""
        return self._emit(now=now)

    def quiet_until(self) -> float:
        """A time before which `flush(now)` emits nothing: the oldest waiting reference frame's
        t + max_wait_s (a nanosecond early, for round-off); inf with none waiting, -inf when it is
        ready now."""
        if not self._pending:
            return math.inf
        t = self._pending[0][0]
        if self._others_reached(t):
            return -math.inf
        return t + self.max_wait_s - 1e-9

    def _others_reached(self, t: float) -> bool:
        """Every camera but the reference has a frame at or after time `t` (a plain loop: this is
        asked at every frame and every poll)."""
        frames = self._frames
        for c in range(1, self.cameras):
            buffer = frames[c]
            if not buffer or not buffer[-1][0] >= t:
                return False
        return True

    def _emit(self, now: float) -> list[SyncedFrame]:
        out = []
        pending = self._pending
        while pending:
            t, x0 = pending[0]
            if not self._others_reached(t) and now - t < self.max_wait_s:
                break
            pending.popleft()
            dots = np.empty((self.cameras, self.slots, 2))
            dots[0] = x0
            for c in range(1, self.cameras):
                self._at_into(c, t, dots[c])
            out.append(SyncedFrame(t, dots))
        return out

    def _at_into(self, camera: int, t: float, out: NDArray[np.float64]) -> None:
        """Camera `camera`'s dots at time t from its buffered frames, written into `out` (K, 2)
        (an interpolation straight into it: no array made and copied per frame)."""
        frames = self._frames[camera]
        if not frames:
            out.fill(np.nan)
            return
        after = None  # the oldest frame at or after t, searched from the newest end
        for i in range(len(frames) - 1, -1, -1):
            if frames[i][0] < t:
                break
            after = i
        if self.method == "nearest":
            out[:] = min(frames, key=lambda f: abs(f[0] - t))[1]
            return
        if after is None:  # nothing newer: extrapolate from the last two frames
            out[:] = self._extrapolate(frames, t)
            return
        t1, x1 = frames[after]
        if after == 0:
            if t1 - t <= self.hold_s:
                out[:] = x1
            else:
                out.fill(np.nan)
            return
        t0, x0 = frames[after - 1]
        kernels.interpolate_slots(t0, x0, t1, x1, t, self.jump_px, self.hold_s, out)

    def _extrapolate(self, frames: deque[tuple[float, NDArray[np.float64]]], t: float) -> NDArray[np.float64]:
        t1, x1 = frames[-1]
        if t - t1 > self.max_wait_s:
            return np.full((self.slots, 2), np.nan)
        if len(frames) < 2:
            return x1.copy()
        t0, x0 = frames[-2]
        out: NDArray[np.float64] = x1 + (t - t1) / (t1 - t0) * (x1 - x0) if t1 > t0 else x1.copy()
        bad = ~(np.isfinite(x0).all(axis=1)) | (np.linalg.norm(x1 - x0, axis=1) > self.jump_px)
        out[bad] = x1[bad]
        return out
