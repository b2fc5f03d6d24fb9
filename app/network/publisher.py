"""Publishing a rig over Zenoh: `RigPublisher` puts frames on the keys of `messages`, `RigWatcher`
publishes whatever a running `RigStream` tracks and reads.

`RigPublisher` declares one publisher per key (markers, each camera's dots, throws), JSON-encoded,
reliable and with congestion control BLOCK: a slow subscriber slows the publisher rather than
losing frames (at the rig's 100 Hz a frame is a few hundred bytes). Each key counts its own `seq`
from 0, so a subscriber sees a lost or reordered frame. Puts are serialised by a lock (the rig
loop, the watcher thread and a throw may publish at once).

`RigWatcher` is for a rig that something else polls (the session's rig loop under `demo` and
`serve`): a thread reads the frames the stream kept since it last looked (`tracked_since`, each
camera's `recent`) every `period_s` and publishes them in order; the stream keeps 1000 tracked
frames, ten seconds at 100 Hz, far more than a period. `track --publish`, which polls the rig
itself, publishes each frame as it comes out instead (`RigPublisher.publish_markers`).
"""

from __future__ import annotations

import threading
import time
from collections.abc import Sequence
from typing import Any

from wiithrow.app.network.messages import (
    dots_key,
    dots_message,
    markers_key,
    markers_message,
    throw_message,
    throws_key,
)
from wiithrow.app.rig.stream import RigStream
from wiithrow.vision.tracker import TrackedFrame
from wiithrow.vision.wiimote.frames import IRFrame


class RigPublisher:
    """Puts one rig's markers, dots and throws on `wiithrow/<rig>/...` through `session` (open)."""

    def __init__(self, session: Any, rig: str, camera_names: Sequence[str], frame_name: str) -> None:
        import zenoh

        options = {
            "encoding": zenoh.Encoding.APPLICATION_JSON,
            "congestion_control": zenoh.CongestionControl.BLOCK,
            "reliability": zenoh.Reliability.RELIABLE,
        }
        self.rig = rig
        self.frame_name = frame_name
        self.camera_names = list(camera_names)
        self._markers = session.declare_publisher(markers_key(rig), **options)
        self._dots = [session.declare_publisher(dots_key(rig, name), **options) for name in self.camera_names]
        self._throws = session.declare_publisher(throws_key(rig), **options)
        self.markers_sent = 0
        self.dots_sent = [0] * len(self.camera_names)
        self.throws_sent = 0
        self._lock = threading.Lock()

    def publish_markers(self, frame: TrackedFrame, sent: float | None = None) -> int:
        """Put one tracked frame; its seq. `sent`: the Unix time to stamp (default: now)."""
        with self._lock:
            seq = self.markers_sent
            self._markers.put(markers_message(self.rig, seq, frame, self.frame_name, sent))
            self.markers_sent += 1
            return seq

    def publish_dots(self, camera: int, frame: IRFrame) -> int:
        with self._lock:
            seq = self.dots_sent[camera]
            self._dots[camera].put(dots_message(self.rig, seq, camera, frame))
            self.dots_sent[camera] += 1
            return seq

    def publish_throw(self, index: int, result: dict[str, Any]) -> int:
        with self._lock:
            seq = self.throws_sent
            self._throws.put(throw_message(self.rig, seq, index, result))
            self.throws_sent += 1
            return seq

    def has_subscribers(self) -> bool:
        """Whether a subscriber of the markers is known (Zenoh's matching status)."""
        status = self._markers.matching_status  # a MatchingStatus in zenoh 1.x (its stub says bool)
        return bool(getattr(status, "matching", status))

    def wait_for_subscribers(self, timeout_s: float) -> bool:
        """Wait up to `timeout_s` for a subscriber of the markers; whether one came."""
        end = time.monotonic() + timeout_s
        while not self.has_subscribers():
            if time.monotonic() >= end:
                return False
            time.sleep(0.01)
        return True

    def summary(self) -> str:
        dots = sum(self.dots_sent)
        return (
            f"published {self.markers_sent} marker frames, {dots} camera frames and {self.throws_sent} throws "
            f"under wiithrow/{self.rig}/"
        )

    def close(self) -> None:
        with self._lock:
            for publisher in [self._markers, *self._dots, self._throws]:
                try:
                    publisher.undeclare()
                except Exception:  # the session closed first: nothing left to undeclare
                    pass


class DotsFollower:
    """Publishes each camera's frames that a RigStream kept since the last call, in order."""

    def __init__(self, publisher: RigPublisher, rig: RigStream) -> None:
        self.publisher = publisher
        self.rig = rig
        self._last_seq = [-1] * len(rig.drivers)

    def publish_new(self) -> int:
        count = 0
        for camera in range(len(self.rig.drivers)):
            for frame in self.rig.recent(camera, 100):
                if frame.seq > self._last_seq[camera]:
                    self.publisher.publish_dots(camera, frame)
                    self._last_seq[camera] = frame.seq
                    count += 1
        return count


class RigWatcher:
    """A thread that publishes what `rig` tracks and reads while something else polls it."""

    def __init__(self, publisher: RigPublisher, rig: RigStream, period_s: float = 0.005) -> None:
        self.publisher = publisher
        self.rig = rig
        self.period_s = period_s
        self._dots = DotsFollower(publisher, rig)
        self._last_t = -float("inf")
        self._last_tracker: object | None = None
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, name="wiithrow-zenoh", daemon=True)

    def start(self) -> None:
        self._thread.start()

    def publish_new(self) -> None:
        """Publish the frames tracked and read since the last call."""
        if self.rig.tracker is not self._last_tracker:  # a new calibration: its frames start afresh
            self._last_tracker = self.rig.tracker
            self._last_t = -float("inf")
        for frame in self.rig.tracked_since(self._last_t):
            self.publisher.publish_markers(frame)
            self._last_t = frame.t
        self._dots.publish_new()

    def _run(self) -> None:
        while not self._stop.wait(self.period_s):
            try:
                self.publish_new()
            except Exception:  # the session closed under us: stop publishing, the rig goes on
                return

    def stop(self) -> None:
        self._stop.set()
        if self._thread.is_alive():
            self._thread.join(timeout=2.0)
        try:
            self.publish_new()
        except Exception:
            pass
