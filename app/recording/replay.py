"""Replaying a recording's raw reports through the same pipeline, streamed from the file.

`Replay` is the third `wiithrow.app.rig.source.MarkerSource`: it decodes the recorded raw HID
reports, with their receive times, with one `ReportDecoder` per camera (the same parsing and frame
assembly as a live driver, with no transport), and repeats the rig's recorded steps (frames
processed per camera, flushes, calibrations) on its own `TrackingPipeline`, the local rig's: the
synchroniser, correspondence and tracker run again and give the recorded markers exactly, ids
included, and its listeners get the same events. With another calibration (`Ps`) the same reports
are tracked with it instead. `frames()` replays everything in order (or paced to the wall clock),
yielding each tracked frame as it comes; `run()` is the same as a list; `poll()` replays what was
recorded up to its clock's now (a `SimClock` that starts at the recording's first message), so a
consumer can let time pass over a replay as over a live rig.

The messages are read from the file as the replay goes (`Recording.messages()`, one chunk at a
time), and the replay keeps only what the pipeline keeps (recent frames): its memory does not grow
with the file. It stops where the file's intact part ends (`end` says why), or at a message that
does not fit (a report or step that does not parse, or reports that run more than
`MAX_PENDING_FRAMES` frames ahead of the rig's steps, which no recorder writes).
"""

from __future__ import annotations

import os
import time
from collections.abc import Callable, Iterator
from typing import Any

import numpy as np
from numpy.typing import NDArray

from wiithrow.app.recording import channels as ch
from wiithrow.app.recording.channels import RecordingError
from wiithrow.app.recording.reading import RecordedMessage, Recording, read_recording
from wiithrow.app.rig.pipeline import TrackingPipeline
from wiithrow.clock import SimClock
from wiithrow.listeners import batch
from wiithrow.vision.errors import FileFormatError, VisionError
from wiithrow.vision.tracked_frame import TrackedFrame
from wiithrow.vision.wiimote.decoder import ReportDecoder
from wiithrow.vision.wiimote.frames import IRFrame

#: Decoded frames of a camera that may wait for the rig's step that processes them: a live rig
#: processes what it read at every poll (a few frames), so 10,000 (100 s at 100 Hz) is never
#: reached by a recording, and bounds what a file of reports without steps can make a replay hold.
MAX_PENDING_FRAMES = 10_000


class Replay(TrackingPipeline):
    """A recording's reports through decoders, synchroniser and tracker again (module docstring).

    `Ps`: track with these projection matrices instead of the recorded calibration. It opens a
    pass over the file at once (and reads its first chunk: `RecordingError` for a chunk beyond the
    limits); `close()` releases the file before the end."""

    def __init__(self, recording: Recording, Ps: NDArray[np.float64] | None = None) -> None:
        self.recording = recording
        self.Ps_override = None if Ps is None else np.asarray(Ps, dtype=float)
        if self.Ps_override is not None and len(self.Ps_override) != recording.cameras:
            raise RecordingError(
                f"the calibration has {len(self.Ps_override)} cameras, the recording {recording.cameras} remotes"
            )
        self.end: str | None = None
        self._stream = recording.messages()
        self._stopped = False
        self._next = self._following()  # the next message to replay (None: no more)
        #: the log times on the rig's clock (a recording's log times are Unix time: `wall_time`)
        self.wall = recording.wall
        #: the recording's first message's time (s, the rig's clock): where the replay's clock starts
        self.first = self.wall.t_of(self._next.log_time) if self._next is not None else 0.0
        #: what the rows' t counts from: the tracking start the recording holds (`/rig/start`, read
        #: before the frames tracked after it), else (older recordings) the first message's time
        self.start = self.first
        names = [f"replay{c}" for c in range(recording.cameras)]
        super().__init__(names, SimClock(self.first))
        self.decoders = [ReportDecoder(name=name) for name in names]
        self.refused = 0  # steps the rig refused, live and in the replay alike
        self._pending: list[list[IRFrame]] = [[] for _ in names]

    def connect(self) -> None:
        """Nothing to open: the file was opened with the replay."""

    def close(self) -> None:
        """Release the file (the replay ends there)."""
        self._stream.close()
        self._next = None

    def _following(self) -> RecordedMessage | None:
        """The stream's next message (None at its end, which `end` then says)."""
        try:
            return next(self._stream)
        except StopIteration:
            self.end = self.end or self._stream.end
            return None
        except BaseException:
            self._stream.close()
            raise

    def poll(self) -> None:
        """Replay the messages recorded up to the clock's now (their events one batch:
        `wiithrow.listeners.batch`, as a local rig's poll's)."""
        with batch(), self._lock:
            limit = self.wall.stamp_ns(self.clock.now())
            while not self._stopped and self._next is not None and self._next.log_time <= limit:
                self._replay_next()

    def frames(self, *, speed: float | None = None) -> Iterator[TrackedFrame]:
        """Replay every message left, yielding the tracked frames in order as they come (none kept).
        `speed`: pace the replay to the wall clock at this multiple of real time (None: at once)."""
        t0_log: int | None = None
        t0_wall = time.monotonic()
        while not self._stopped and self._next is not None:
            log_time = self._next.log_time
            if speed is not None:
                t0_log = log_time if t0_log is None else t0_log
                wait = (log_time - t0_log) / 1e9 / speed - (time.monotonic() - t0_wall)
                if wait > 0:
                    time.sleep(wait)
            with self._lock:
                tracked = self._replay_next()
            yield from tracked

    def run(
        self, on_frame: Callable[[TrackedFrame], object] | None = None, *, speed: float | None = None
    ) -> list[TrackedFrame]:
        """`frames()` as a list (every tracked frame kept: for recordings that fit in memory), each
        also given to `on_frame`."""
        out: list[TrackedFrame] = []
        for frame in self.frames(speed=speed):
            out.append(frame)
            if on_frame is not None:
                on_frame(frame)
        return out

    def _replay_next(self) -> list[TrackedFrame]:
        """Replay one message (its time on the clock); the tracked frames it made."""
        assert self._next is not None
        topic, log_time, data = self._next
        self._next = self._following()
        self.clock.sleep(self.wall.t_of(log_time) - self.clock.now())
        if topic == ch.TRACKING_START:
            try:
                self.start = float(self._next_message(topic, log_time, data)["t"])
            except (FileFormatError, KeyError, TypeError, ValueError):  # damaged: t from the first message
                pass
            return []
        if not (topic.endswith("/reports") or topic in (ch.STEPS, ch.CALIBRATION)):
            return []  # what the rig made of them (dots, markers) or a session's: not replayed
        try:
            tracked = self._step(topic, self._next_message(topic, log_time, data))
        except FileFormatError as exc:  # not JSON, or nested too deep: damage, said in one line
            self.end = f"{self.recording.path}: a damaged {topic} message ({exc}); replay stopped there"
            tracked = None
        except (KeyError, TypeError, ValueError, IndexError) as exc:  # a message that does not fit: damage
            self.end = (
                f"{self.recording.path}: a damaged {topic} message ({type(exc).__name__}: {exc}); replay stopped there"
            )
            tracked = None
        if tracked is None:
            self._stopped = True
            self.close()
            return []
        return tracked

    @staticmethod
    def _next_message(topic: str, log_time: int, data: bytes) -> dict[str, Any]:
        message = RecordedMessage(topic, log_time, data).json()
        if not isinstance(message, dict):
            raise TypeError(f"a JSON {type(message).__name__}, not an object")
        return message

    def _step(self, topic: str, message: dict[str, Any]) -> list[TrackedFrame] | None:
        pending = self._pending
        if topic.endswith("/reports"):
            c = int(message["camera"])
            batch = [(float(t), bytes.fromhex(d)) for t, d in zip(message["t"], message["data"])]
            pending[c] += self.decoders[c].decode(batch)
            if len(pending[c]) > MAX_PENDING_FRAMES:
                self.end = (
                    f"{self.recording.path}: camera {c}'s reports run more than {MAX_PENDING_FRAMES} frames ahead "
                    "of the rig's steps (no recorder writes that); replay stopped there"
                )
                return None
            return []
        if topic == ch.STEPS:
            if message["step"] == "flush":
                return self.flush(float(message["t"]))
            c, n = int(message["camera"]), int(message["frames"])
            if len(pending[c]) < n:
                self.end = f"{self.recording.path}: camera {c}'s reports are missing for a step; replay stopped there"
                return None
            frames, pending[c] = pending[c][:n], pending[c][n:]
            last = self.tracked[-1] if self.tracked else None
            try:
                return self.process(c, frames)
            except VisionError:  # refused live too (a frame older than the one before): the rest is lost alike
                self.refused += 1
                return self._tracked_after(last)
        if topic == ch.CALIBRATION:
            Ps = self.Ps_override if self.Ps_override is not None else np.asarray(message["Ps"], dtype=float)
            self.set_calibration(Ps)
        return []

    def _tracked_after(self, last: TrackedFrame | None) -> list[TrackedFrame]:
        """The rig's tracked frames kept after `last` (those a refused step made before failing)."""
        tracked = list(self.tracked)
        for i in range(len(tracked) - 1, -1, -1):
            if tracked[i] is last:
                return tracked[i + 1 :]
        return tracked


def replay_markers(
    path: str | os.PathLike[str], Ps: NDArray[np.float64] | None = None
) -> tuple[Replay, list[TrackedFrame]]:
    """Read and replay a recording at once: the replay (its `end`) and every tracked frame (a list:
    for recordings whose frames fit in memory; `Replay.frames()` streams them)."""
    replay = Replay(read_recording(path), Ps)
    try:
        return replay, replay.run()
    finally:
        replay.close()
