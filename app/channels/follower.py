"""`RigFollower`: what a marker source tracks and reads, handed to an in-process sink as it happens.

It listens to a source's events (`wiithrow.app.rig.events`): each camera's frames processed (their
dots, and the tracked frames they completed) and each flush (the tracked frames it completed) are
handed to a `FramePublisher` in the order they happen, each frame once, and each recalibration
(`publish_calibration`). The events are queued as they come (a sink that waits never holds the
rig's lock) and handed over by a thread (`thread=True`), or by `put_pending()`, called after each
poll by whoever polls the source itself (`thread=False`: the simulated loopback's `RigPublisher`,
`wiithrow.app.worlds.remote`), or, for a sink whose calls never wait (`inline=True`), in the
source's own thread as each event is told, under its lock. (A sink in a writer process follows its
source itself: `sink_process.SinkProcess.follow`.)
"""

from __future__ import annotations

import queue
import threading
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
    """Publishes what `source` tracks and reads, as it happens (see the module docstring):
    `start()` subscribes (and starts the thread), `stop()` unsubscribes and puts what waits.
    `inline`: no queue and no thread, each event published as the source tells it (a publisher
    that never waits only: the module docstring)."""

    def __init__(
        self, publisher: FramePublisher, source: MarkerSource, *, thread: bool = True, inline: bool = False
    ) -> None:
        self.publisher = publisher
        self.source = source
        self.inline = inline
        self.threaded = thread and not inline
        self._queue: queue.SimpleQueue[RigEvent | None] = queue.SimpleQueue()
        self._unsubscribe: Unsubscribe | None = None
        self._thread: threading.Thread | None = None
        self._failed = False

    def start(self) -> None:
        with self.source.lock:  # between two polls: every frame from now on, once
            self._unsubscribe = self.source.subscribe(self.publish if self.inline else self._queue.put)
        if self.threaded:
            self._thread = threading.Thread(target=self._run, name="wiithrow-follower", daemon=True)
            self._thread.start()

    def publish(self, event: RigEvent) -> None:
        """Put what one event brought: a camera's dots, then the tracked frames."""
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
        """Put what the events since the last call brought (`thread=False`); how many events."""
        count = 0
        while True:
            try:
                event = self._queue.get_nowait()
            except queue.Empty:
                return count
            if event is not None:
                self.publish(event)
                count += 1

    def _run(self) -> None:
        while (event := self._queue.get()) is not None:
            if self._failed:
                continue
            try:
                self.publish(event)
            except Exception:  # the Zenoh session closed under us: stop publishing, the rig goes on
                self._failed = True

    def stop(self) -> None:
        unsubscribe, self._unsubscribe = self._unsubscribe, None
        if unsubscribe is not None:
            unsubscribe()
        if self._thread is not None:
            self._queue.put(None)
            self._thread.join(timeout=2.0)
            self._thread = None
        else:
            self.put_pending()
