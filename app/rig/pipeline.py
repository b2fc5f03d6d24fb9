"""Frames -> synchronised instants -> tracked markers: `TrackingPipeline`, what the local rig and
the replay share (the remote source receives what another host's pipeline tracked).

It owns, for C >= 2 cameras, the synchroniser (`vision/sync.py`: each camera's dots
interpolated to the reference camera's frame times), the tracker (`vision/tracker.py`, once
there is a calibration), what is kept for several readers (each camera's recent frames, the
recent synchronised and tracked frames), the calibration in use with its revision, and the one
stream of events its listeners get (`wiithrow.app.rig.events`, under its lock, in order):

    process(camera, frames) -> FramesProcessed      flush(now) -> Flushed
    set_calibration(Ps)     -> CalibrationChanged (revision + 1)

How it synchronises and tracks is given once, as factories (`synchronizer(cameras)`,
`tracker(Ps)`, by default `FrameSynchronizer` and `MarkerTracker` with their defaults), and kept:
`set_calibration` builds its tracker with the given factory, `restart()` (a fresh synchroniser
and tracker, the state a replay starts from) builds both with them, so no option is lost.
"""

from __future__ import annotations

import threading
from collections import deque
from collections.abc import Callable, Sequence

import numpy as np
from numpy.typing import NDArray

from wiithrow.app.rig.events import CalibrationChanged, Flushed, FramesProcessed, ReportsRead, RigEvent, RigListener
from wiithrow.app.rig.kept_frames import KeptFrames, later_than
from wiithrow.app.rig.stage_stamps import StageStamps
from wiithrow.clock import Clock
from wiithrow.listeners import Listeners, Unsubscribe
from wiithrow.vision.sync import FrameSynchronizer, SyncedFrame
from wiithrow.vision.tracker import MarkerTracker, TrackedFrame
from wiithrow.vision.wiimote.frames import IRFrame

#: Builds the synchroniser of C cameras (e.g. `functools.partial(FrameSynchronizer, method="nearest")`).
SynchronizerFactory = Callable[[int], FrameSynchronizer]
#: Builds the tracker of a calibration's projection matrices (C, 3, 4).
TrackerFactory = Callable[[NDArray[np.float64]], MarkerTracker]


class TrackingPipeline(KeptFrames):
    """Tracked 3D markers from C >= 2 cameras' frames (see the module docstring).

    `Ps=None`: no calibration yet; frames are synchronised and kept but nothing is tracked.
    `history`: frames kept per camera (10 x as many synchronised and tracked frames)."""

    def __init__(
        self,
        camera_names: Sequence[str],
        clock: Clock,
        Ps: NDArray[np.float64] | None = None,
        *,
        synchronizer: SynchronizerFactory = FrameSynchronizer,
        tracker: TrackerFactory = MarkerTracker,
        history: int = 100,
    ) -> None:
        self.clock = clock
        self._camera_names = list(camera_names)
        self._make_sync = synchronizer
        self._make_tracker = tracker
        self.sync = synchronizer(len(self._camera_names))
        self.tracker: MarkerTracker | None = None
        self._Ps: NDArray[np.float64] | None = None
        self._revision = 0
        self._history: list[deque[IRFrame]] = [deque(maxlen=history) for _ in self._camera_names]
        self.tracked: deque[TrackedFrame] = deque(maxlen=10 * history)  # recent tracked frames
        self.synced: deque[SyncedFrame] = deque(maxlen=10 * history)  # recent synchronised frames
        self._lock = threading.RLock()
        self.events: Listeners[RigEvent] = Listeners("the rig's events")
        self.stamps: StageStamps | None = None  # when each tracked frame passed each stage (a benchmark's)
        if Ps is not None:
            self.set_calibration(Ps)

    # -- what the source is ------------------------------------------------------------------------

    @property
    def camera_names(self) -> list[str]:
        return list(self._camera_names)

    @property
    def camera_count(self) -> int:
        return len(self._camera_names)

    @property
    def Ps(self) -> NDArray[np.float64] | None:
        return self._Ps

    @property
    def calibrated(self) -> bool:
        return self._Ps is not None

    @property
    def calibration_revision(self) -> int:
        return self._revision

    @property
    def lock(self) -> threading.RLock:
        """Held while the pipeline reads and tracks: hold it to subscribe between two steps."""
        return self._lock

    def subscribe(self, listener: RigListener) -> Unsubscribe:
        return self.events.subscribe(listener)

    def calibration_refused(self) -> str:
        return ""

    def reports_listener(self, camera: int) -> Callable[[Sequence[tuple[float, bytes]]], None]:
        """A listener of camera `camera`'s raw reports (a `ReportDecoder`'s) that tells this
        pipeline's listeners (`ReportsRead`): how the raw reports a recording keeps reach it."""

        def reports(batch: Sequence[tuple[float, bytes]]) -> None:
            if self.events:
                self.events.emit(ReportsRead(camera, batch))

        return reports

    # -- the steps --------------------------------------------------------------------------------

    def set_calibration(self, Ps: NDArray[np.float64]) -> None:
        """Track with these projection matrices from now on (a new tracker: ids restart)."""
        Ps = np.asarray(Ps, dtype=float)
        if len(Ps) != self.camera_count:
            raise ValueError(f"{self.camera_count} drivers for {len(Ps)} calibrated cameras")
        with self._lock:
            self.tracker = self._make_tracker(Ps)
            self._Ps = Ps
            self._revision += 1
            self.tracked.clear()
            self.events.emit(CalibrationChanged(Ps, self._revision))

    def restart(self) -> None:
        """A fresh synchroniser and tracker, built as before, same calibration (track ids restart)."""
        with self._lock:
            self.sync = self._make_sync(self.camera_count)
            if self._Ps is not None:
                self.tracker = self._make_tracker(self._Ps)
                self.tracked.clear()

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
            if self.events:
                self.events.emit(Flushed(now, len(synced), out))
        return out

    def process(self, camera: int, frames: Sequence[IRFrame]) -> list[TrackedFrame]:
        """Feed one camera's decoded frames; return the tracked frames they completed."""
        if not frames and not self.events:  # nothing to feed, no one to tell (most polls of a simulation)
            return []
        out = []
        stamps = self.stamps
        decoded = synced_at = self.clock.now() if stamps is not None else 0.0
        with self._lock:
            history = self._history[camera]
            try:
                for frame in frames:
                    history.append(frame)
                    done = self.sync.push(camera, frame.t_device, frame.dots)
                    if stamps is not None and done:
                        synced_at = self.clock.now()
                    for synced in done:
                        self.synced.append(synced)
                        if self.tracker is not None:
                            out.append(self.tracker.update(synced.t, synced.dots))
                            self.tracked.append(out[-1])
                            if stamps is not None:
                                stamps.frame(out[-1].t, frame.t, decoded, synced_at, self.clock.now())
            finally:  # told even when a frame is refused (older than the one before): a replay fails alike
                if self.events:
                    self.events.emit(FramesProcessed(camera, frames, out))
        return out

    # -- reading what was kept ----------------------------------------------------------------------

    def synced_since(self, t: float) -> list[SyncedFrame]:
        with self._lock:
            return later_than(self.synced, t)
