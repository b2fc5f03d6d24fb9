"""Publishing a rig over Zenoh: `RigPublisher` puts frames on the keys of `messages`,
`RigFollower` publishes what a marker source tracks and reads, as it happens.

`RigPublisher` declares one publisher per key (markers, each camera's dots, throws, and who
publishes), JSON-encoded, reliable and with congestion control BLOCK: a slow subscriber slows the
publisher rather than losing frames (at the rig's 100 Hz a frame is a few hundred bytes). Each key
counts its own `seq` from 0, so a subscriber sees a lost or reordered frame; every message says who
sent it (`messages.Sender`: the session's Zenoh id and a stream id drawn at start, `announcement()`),
and every sample is signed with the user's secret (its attachment, `frame_auth.FrameSigner`: the
receiver adopts nothing unsigned). Before its first marker frame, and every `ANNOUNCE_EVERY_S` after
it, the publisher says where it runs on `publisher` (`messages.Origin`: host, pid, command), what
the operator is shown before following it. Puts are serialised by a lock (the rig loop, the
follower's thread and a throw may publish at once).

`RigFollower` listens to a source's events (`wiithrow.app.rig.events`): each camera's frames
processed (their dots, and the tracked frames they completed) and each flush (the tracked frames
it completed) are published in the order they happen, each frame once; a recalibration needs no
special care (the frames after it are new events), and is handed to the publisher
(`publish_calibration`: the ROS 2 publisher's /tf_static; Zenoh carries none). `RigFollower` follows
for any `FramePublisher` (this module's `RigPublisher`, `wiithrow.app.ros2`'s `Ros2Publisher`). The events are queued as they come (a put
that blocks never holds the rig's lock) and put by a thread (`thread=True`: the session's rig loop
under `demo` and `serve` for ROS 2), or by `put_pending()`, called after each poll by whoever polls
the rig itself (`thread=False`: `track --ros2`, the simulated loopback), or, for a publisher whose
calls never wait (`inline=True`: `ZenohProcessPublisher`, `process_publisher`, what `--publish`
runs: each call packs a record into a shared-memory ring), in the rig's own thread as each event
is told, under its lock, with no queue and no thread.

Why a thread and not the rig's own, although a put costs microseconds (the JSON, ~70 µs, is most of
it): with congestion control BLOCK a put waits while the link's queue is full, behind a slow
subscriber or any other message on the session, and the rig's thread must never wait for a
subscriber. The thread's cost is one handoff of the interpreter per frame: woken by a tracked
frame, it waits for the interpreter while the rig's thread and the dashboard's refresh run. Hence `--publish` runs `process_publisher`'s writer process, which does the JSON and the
puts with this class on an interpreter of its own; this process keeps only the hand-over.
"""

from __future__ import annotations

import queue
import threading
import time
from collections.abc import Sequence
from typing import Any, Protocol

import numpy as np
from numpy.typing import NDArray

from wiithrow.app.network.frame_auth import FrameSigner, secret_path
from wiithrow.app.network.messages import (
    MarkerRows,
    Origin,
    Sender,
    dots_key,
    dots_message,
    markers_key,
    markers_message,
    publisher_key,
    publisher_message,
    throw_message,
    throws_key,
)
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


#: How often a publisher says where it runs (s): a subscriber that starts later learns it within this.
ANNOUNCE_EVERY_S = 1.0


class RigPublisher:
    """Puts one rig's markers, dots and throws on `wiithrow/<rig>/...` through `zenoh_session`
    (open), signed with `signer` (default: this user's secret); `origin`: where it runs (default:
    this process; a writer process names the process it writes for)."""

    def __init__(
        self,
        zenoh_session: Any,
        rig: str,
        camera_names: Sequence[str],
        frame_name: str,
        *,
        origin: Origin | None = None,
        signer: FrameSigner | None = None,
    ) -> None:
        import zenoh

        options = {
            "encoding": zenoh.Encoding.APPLICATION_JSON,
            "congestion_control": zenoh.CongestionControl.BLOCK,
            "reliability": zenoh.Reliability.RELIABLE,
        }
        self.rig = rig
        self.frame_name = frame_name
        self.camera_names = list(camera_names)
        self.sender = Sender.of(zenoh_session)
        self.origin = origin if origin is not None else Origin.of_this_process()
        self.signer = signer if signer is not None else FrameSigner.for_this_user()
        self._keys = {
            "markers": markers_key(rig),
            "throws": throws_key(rig),
            "publisher": publisher_key(rig),
            **{f"dots{i}": dots_key(rig, name) for i, name in enumerate(self.camera_names)},
        }
        self._markers = zenoh_session.declare_publisher(self._keys["markers"], **options)
        self._dots = [
            zenoh_session.declare_publisher(self._keys[f"dots{i}"], **options) for i in range(len(camera_names))
        ]
        self._throws = zenoh_session.declare_publisher(self._keys["throws"], **options)
        self._publisher = zenoh_session.declare_publisher(self._keys["publisher"], **options)
        self.markers_sent = 0
        self.dots_sent = [0] * len(self.camera_names)
        self.throws_sent = 0
        self.announcements_sent = 0
        self._announced_at = -float("inf")
        self._lock = threading.Lock()

    def _put(self, publisher: Any, key: str, text: str) -> None:
        """Put `text` on `key` with its signature (the caller holds the lock)."""
        data = text.encode("utf-8")
        publisher.put(data, attachment=self.signer.sign(key, data))

    def _announce_if_due(self) -> None:
        """Say where this publisher runs, before its first marker frame and every ANNOUNCE_EVERY_S."""
        now = time.monotonic()
        if now - self._announced_at < ANNOUNCE_EVERY_S:
            return
        self._announced_at = now
        message = publisher_message(self.rig, self.announcements_sent, self.origin, sender=self.sender)
        self._put(self._publisher, self._keys["publisher"], message)
        self.announcements_sent += 1

    def publish_markers(
        self, frame: TrackedFrame | MarkerRows, sent: float | None = None, *, seq: int | None = None
    ) -> int:
        """Put one tracked frame (or its values, `MarkerRows`); its seq. `sent`: the Unix time to
        stamp (default: now); `seq`: the number another process gave it (`ZenohProcessPublisher`;
        default: the next)."""
        with self._lock:
            seq = self.markers_sent if seq is None else seq
            self._announce_if_due()
            message = markers_message(self.rig, seq, frame, self.frame_name, sent, sender=self.sender)
            self._put(self._markers, self._keys["markers"], message)
            self.markers_sent = seq + 1
            return seq

    def publish_dots(self, camera: int, frame: IRFrame, *, seq: int | None = None) -> int:
        with self._lock:
            seq = self.dots_sent[camera] if seq is None else seq
            self._put(
                self._dots[camera],
                self._keys[f"dots{camera}"],
                dots_message(self.rig, seq, camera, frame, sender=self.sender),
            )
            self.dots_sent[camera] = seq + 1
            return seq

    def publish_throw(self, index: int, result: dict[str, Any]) -> int:
        with self._lock:
            seq = self.throws_sent
            self._put(
                self._throws, self._keys["throws"], throw_message(self.rig, seq, index, result, sender=self.sender)
            )
            self.throws_sent += 1
            return seq

    def publish_calibration(self, Ps: NDArray[np.float64] | None) -> None:
        """Nothing: the Zenoh keys carry no calibration (a subscriber checks against its own settings)."""

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

    def announcement(self) -> str:
        """Who publishes (what a subscriber pins: `serve --markers-source`), said once at start."""
        return (
            f"publishing under wiithrow/{self.rig}/ as source {self.sender.source}, stream {self.sender.stream}, "
            f"signed with this user's secret ({secret_path()})"
        )

    def summary(self) -> str:
        dots = sum(self.dots_sent)
        return (
            f"published {self.markers_sent} marker frames, {dots} camera frames and {self.throws_sent} throws "
            f"under wiithrow/{self.rig}/"
        )

    def close(self) -> None:
        with self._lock:
            for publisher in [self._markers, *self._dots, self._throws, self._publisher]:
                try:
                    publisher.undeclare()
                except Exception:  # the session closed first: nothing left to undeclare
                    pass


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
