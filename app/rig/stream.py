"""The live rig: C Wiimote drivers -> frame synchroniser -> marker tracker.

`RigStream` owns the path from the remotes' frames to tracked 3D markers in the calibration's
frame (`link1` for the rig on the robot). Before there is a calibration it still reads the remotes
and keeps each camera's recent frames (what the robot-driven calibration averages). It works the same over real remotes and simulated ones:
with a simulated clock the caller advances time and calls `poll()`, with the system clock a loop
calls `poll()` at its own pace (each driver's reports queue up in the HID buffer meanwhile).

Frames are synchronised on the driver's estimate of when the remote sent them (`t_device`), which
removes the jitter of reading reports in batches. The latest dots of every camera, the recent
synchronised frames (what a wand recording keeps, calibrated or not) and the recent tracked
frames are kept, so that several readers (an operation that polls, the dashboard that
draws) see the same frames; `poll` and `process` are serialised by a lock.

An `observer` (a `RigObserver`, e.g. a recording) is told, under that lock, of every step that
changes what is tracked: each camera's frames processed, each flush at a time, each new
calibration, with the tracked frames they made; replaying those steps in order gives the same
markers. `restart()` gives a fresh synchroniser and tracker, the state a replay starts from.
"""

from __future__ import annotations

import threading
from collections import deque
from collections.abc import Sequence
from typing import Protocol

import numpy as np
from numpy.typing import NDArray

from wiithrow.vision.sync import FrameSynchronizer, SyncedFrame
from wiithrow.vision.tracker import MarkerTracker, TrackedFrame
from wiithrow.vision.wiimote.device import WiimoteDriver
from wiithrow.vision.wiimote.frames import IRFrame


class RigObserver(Protocol):
    """What a `RigStream` tells its observer (called under the stream's lock; must not raise)."""

    def processed(self, camera: int, frames: Sequence[IRFrame], tracked: Sequence[TrackedFrame]) -> None: ...

    def flushed(self, now: float, synced: int, tracked: Sequence[TrackedFrame]) -> None: ...

    def calibrated(self, Ps: NDArray[np.float64]) -> None: ...


class RigStream:
    """Tracked 3D markers from C >= 2 drivers and the cameras' projection matrices (C, 3, 4).

    `Ps=None`: no calibration yet; frames are read and kept (`recent`) but nothing is tracked.
    """

    def __init__(
        self,
        drivers: Sequence[WiimoteDriver],
        Ps: NDArray[np.float64] | None = None,
        *,
        tracker: MarkerTracker | None = None,
        synchronizer: FrameSynchronizer | None = None,
        history: int = 100,
    ) -> None:
        self.drivers = list(drivers)
        self.sync = synchronizer or FrameSynchronizer(len(self.drivers))
        self.tracker: MarkerTracker | None = None
        self._history: list[deque[IRFrame]] = [deque(maxlen=history) for _ in self.drivers]
        self.tracked: deque[TrackedFrame] = deque(maxlen=10 * history)  # recent tracked frames
        self.synced: deque[SyncedFrame] = deque(maxlen=10 * history)  # recent synchronised frames
        self._lock = threading.RLock()
        self.observer: RigObserver | None = None
        if tracker is not None:
            self.tracker = tracker
        elif Ps is not None:
            self.set_calibration(Ps)

    def calibration_refused(self) -> str:
        """Why this rig cannot be calibrated here ("" when it can): a rig whose markers another
        host tracks says so, before an operation moves the arm for nothing."""
        return ""

    def set_calibration(self, Ps: NDArray[np.float64]) -> None:
        """Track with these projection matrices from now on (a new tracker: ids restart)."""
        if len(Ps) != len(self.drivers):
            raise ValueError(f"{len(self.drivers)} drivers for {len(Ps)} calibrated cameras")
        with self._lock:
            self.tracker = MarkerTracker(Ps)
            self.tracked.clear()
            if self.observer is not None:
                self.observer.calibrated(np.asarray(Ps, dtype=float))

    @property
    def lock(self) -> threading.RLock:
        """Held while the rig reads and tracks: hold it to change what observes the rig between
        two polls."""
        return self._lock

    def restart(self) -> None:
        """A fresh synchroniser and tracker, same settings and calibration (track ids restart)."""
        with self._lock:
            s = self.sync
            self.sync = FrameSynchronizer(
                s.cameras, method=s.method, slots=s.slots, jump_px=s.jump_px, hold_s=s.hold_s, max_wait_s=s.max_wait_s
            )
            if self.tracker is not None:
                self.tracker = MarkerTracker(self.tracker.correspondence.Ps)
                self.tracked.clear()

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
            return [f for f in self.tracked if f.t > t]

    def synced_since(self, t: float) -> list[SyncedFrame]:
        """The kept synchronised frames later than time t, oldest first."""
        with self._lock:
            return [f for f in self.synced if f.t > t]

    def latest_tracked(self) -> TrackedFrame | None:
        with self._lock:
            return self.tracked[-1] if self.tracked else None

    def connect(self) -> None:
        """Open every remote and start its camera (raises WiimoteError if one cannot start)."""
        for driver in self.drivers:
            driver.connect()

    def close(self) -> None:
        for driver in self.drivers:
            driver.close()

    def poll(self, timeout_s: float = 0.0) -> list[TrackedFrame]:
        """Read what every remote has sent and return the tracked frames that became complete."""
        with self._lock:
            out: list[TrackedFrame] = []
            for camera, driver in enumerate(self.drivers):
                out += self.process(camera, driver.poll(timeout_s if camera == 0 else 0.0))
            return out + self.flush(self.drivers[0].clock.now())

    def flush(self, now: float) -> list[TrackedFrame]:
        """Track the reference frames that have waited long enough by time `now` (a silent camera)."""
        out = []
        with self._lock:
            synced = self.sync.flush(now)
            for frame in synced:
                self.synced.append(frame)
                if self.tracker is not None:
                    out.append(self.tracker.update(frame.t, frame.dots))
                    self.tracked.append(out[-1])
            if self.observer is not None:
                self.observer.flushed(now, len(synced), out)
        return out

    def process(self, camera: int, frames: Sequence[IRFrame]) -> list[TrackedFrame]:
        """Feed one camera's decoded frames; return the tracked frames they completed."""
        out = []
        with self._lock:
            history = self._history[camera]
            try:
                for frame in frames:
                    history.append(frame)
                    for synced in self.sync.push(camera, frame.t_device, frame.dots):
                        self.synced.append(synced)
                        if self.tracker is not None:
                            out.append(self.tracker.update(synced.t, synced.dots))
                            self.tracked.append(out[-1])
            finally:  # told even when a frame is refused (older than the one before): a replay fails alike
                if self.observer is not None:
                    self.observer.processed(camera, frames, out)
        return out

    def latest_dots(self) -> NDArray[np.float64]:
        """Every camera's most recent dots (C, 4, 2), NaN where none."""
        return np.stack([f.dots if f is not None else np.full((4, 2), np.nan) for f in self.latest])
