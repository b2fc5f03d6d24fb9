"""`RigFollower`: what a marker source tracks and reads, handed to an in-process sink as it happens.

It listens to a source's events (`wiithrow.app.rig.events`): each camera's frames processed (their
dots, and the tracked frames they completed) and each flush (the tracked frames it completed) are
handed to a `FramePublisher` in the order they happen, each frame once, and each recalibration
(`publish_calibration`). The events are queued as they come (a sink that waits never holds the
rig's lock) and handed over by `put_pending()`, called after each poll by whoever polls the source
itself: the simulated loopback's `RigPublisher` (`wiithrow.app.worlds.remote`). (A sink in a
writer process follows its source itself: `sink_process.SinkProcess.follow`.)
"""

from __future__ import annotations

import queue
from typing import Protocol

import numpy as np
from numpy.typing import NDArray

from wiithrow.app.rig.events import CalibrationChanged, Flushed, FramesProcessed, RigEvent
from wiithrow.app.rig.source import MarkerSource
from wiithrow.listeners import Unsubscribe
from wiithrow.vision.tracked_frame import TrackedFrame
from wiithrow.vision.wiimote.frames import IRFrame


class FramePublisher(Protocol):
    """What `RigFollower` hands a source's events to."""

    def publish_markers(self, frame: TrackedFrame) -> int: ...

    def publish_dots(self, camera: int, frame: IRFrame) -> int: ...

    def publish_calibration(self, Ps: NDArray[np.float64] | None) -> None: ...


class RigFollower:
    """Hands what `source` tracks and reads to `publisher` (see the module docstring): `start()`
    subscribes, `put_pending()` hands over what the events since the last call brought, `stop()`
    unsubscribes and hands over what waits."""

    def __init__(self, publisher: FramePublisher, source: MarkerSource) -> None:
        self.publisher = publisher
        self.source = source
        self._queue: queue.SimpleQueue[RigEvent] = queue.SimpleQueue()
        self._unsubscribe: Unsubscribe | None = None

    def start(self) -> None:
        with self.source.lock:  # between two polls: every frame from now on, once
            self._unsubscribe = self.source.subscribe(self._queue.put)

    def publish(self, event: RigEvent) -> None:
        """Hand over what one event brought: a camera's dots, then the tracked frames."""
        if isinstance(event, FramesProcessed):
            for frame in event.frames:
                self.publisher.publish_dots(event.camera, frame)
            for tracked in event.tracked:
                self.publisher.publish_markers(tracked)
        elif isinstance(event, Flushed):
            for tracked in event.tracked:
                self.publisher.publish_markers(tracked)
        elif isinstance(event, CalibrationChanged):
            self.publisher.publish_calibration(event.Ps)

    def put_pending(self) -> int:
        """Hand over what the events since the last call brought; how many events."""
        count = 0
        while True:
            try:
                event = self._queue.get_nowait()
            except queue.Empty:
                return count
            self.publish(event)
            count += 1

    def stop(self) -> None:
        unsubscribe, self._unsubscribe = self._unsubscribe, None
        if unsubscribe is not None:
            unsubscribe()
        self.put_pending()
