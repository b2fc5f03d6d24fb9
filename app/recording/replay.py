"""Reading a recording back and replaying its raw reports through the same pipeline.

`read_recording` reads an MCAP file written by `Recorder` from its start, record by record, as
far as it is intact: a file cut short (a recorder killed) or corrupt in the middle keeps every
message before the damage, and `Recording.end` says where it ends. A file that is not MCAP, not
a wiithrow recording, or from a newer format version is refused (`RecordingError`).

`Replay` is the third `wiithrow.app.rig.source.MarkerSource`: it decodes the recorded raw HID
reports, with their receive times, with one `ReportDecoder` per camera (the same parsing and frame
assembly as a live driver, with no transport), and repeats the rig's recorded steps (frames
processed per camera, flushes, calibrations) on its own `TrackingPipeline`, the local rig's: the
synchroniser, correspondence and tracker run again and give the recorded markers exactly, ids
included, and its listeners get the same events. With another calibration (`Ps`) the same reports
are tracked with it instead. `run()` replays everything at once (or paced to the wall clock);
`poll()` replays what was recorded up to its clock's now (a `SimClock` that starts at the
recording's first message), so a consumer can let time pass over a replay as over a live rig.
"""

from __future__ import annotations

import json
import os
import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from mcap.records import Attachment, Channel, Footer, Header, Message, Metadata
from mcap.stream_reader import StreamReader
from numpy.typing import NDArray

from wiithrow.app.recording import channels as ch
from wiithrow.app.recording.channels import RecordingError
from wiithrow.app.rig.pipeline import TrackingPipeline
from wiithrow.clock import SimClock
from wiithrow.vision.errors import VisionError
from wiithrow.vision.tracker import TrackedFrame
from wiithrow.vision.wiimote.decoder import ReportDecoder
from wiithrow.vision.wiimote.frames import IRFrame

MAGIC = b"\x89MCAP0\r\n"


@dataclass
class Recording:
    """What `read_recording` found: metadata, attachments, and the intact messages in file order
    as (topic, log time in ns, decoded JSON)."""

    path: Path
    metadata: dict[str, str]
    messages: list[tuple[str, int, dict[str, Any]]] = field(default_factory=list)
    attachments: dict[str, bytes] = field(default_factory=dict)
    end: str | None = None  # where a damaged file ends (None: complete)

    @property
    def cameras(self) -> int:
        return int(self.metadata.get("cameras", "2"))

    @property
    def frame_id(self) -> str:
        return self.metadata.get("frame_id", "link1")

    def topic(self, name: str) -> list[dict[str, Any]]:
        return [m for topic, _, m in self.messages if topic == name]


def _records(handle: Any) -> Iterator[Any]:
    yield from StreamReader(handle, validate_crcs=True).records


def read_recording(path: str | os.PathLike[str]) -> Recording:
    """The intact part of a recording (see the module docstring); `RecordingError` when refused."""
    path = Path(path)
    try:
        handle = open(path, "rb")  # noqa: SIM115 - closed below
    except OSError as exc:
        raise RecordingError(f"cannot read {path}: {exc.strerror or exc}") from None
    with handle:
        size = os.fstat(handle.fileno()).st_size
        if handle.read(len(MAGIC)) != MAGIC:
            raise RecordingError(f"{path} is not an MCAP file")
        handle.seek(0)
        recording = Recording(path, {})
        channels: dict[int, str] = {}
        complete = False
        records = _records(handle)
        while True:
            try:
                record = next(records)
            except StopIteration:
                break
            except Exception as exc:  # any damage (truncation, a bad CRC, bad compression) ends the file
                recording.end = _damage(recording, handle, size, exc)
                break
            if isinstance(record, Header) and record.profile != ch.PROFILE:
                raise RecordingError(f"{path} is not a wiithrow recording (MCAP profile {record.profile!r})")
            if isinstance(record, Metadata) and record.name == ch.METADATA_NAME:
                _check_version(path, record.metadata)
                _check_cameras(path, record.metadata)
                recording.metadata = dict(record.metadata)
            elif isinstance(record, Channel):
                channels[record.id] = record.topic
            elif isinstance(record, Attachment):
                recording.attachments[record.name] = bytes(record.data)
            elif isinstance(record, Message):
                topic = channels.get(record.channel_id)
                if topic is None:
                    recording.end = (
                        f"{path}: a message of an unknown channel at byte {handle.tell()}; replayed what came before"
                    )
                    break
                recording.messages.append((topic, record.log_time, json.loads(record.data)))
            elif isinstance(record, Footer):
                complete = True
        if not recording.metadata:
            raise RecordingError(f"{path} is not a wiithrow recording (no {ch.METADATA_NAME!r} metadata)")
        if not complete and recording.end is None:
            recording.end = _damage(recording, handle, size, EOFError("no footer"))
        return recording


def _check_version(path: Path, metadata: dict[str, str]) -> None:
    try:
        version = int(metadata.get("format_version", ""))
    except ValueError:
        raise RecordingError(f"{path}: unreadable format version {metadata.get('format_version')!r}") from None
    if version > ch.FORMAT_VERSION:
        raise RecordingError(
            f"{path} was written in recording format {version}, newer than this wiithrow reads "
            f"(up to {ch.FORMAT_VERSION}): upgrade wiithrow to replay it"
        )


def _check_cameras(path: Path, metadata: dict[str, str]) -> None:
    cameras = metadata.get("cameras", "")
    if metadata.get("digest") != ch.digest(metadata) or not (cameras.isdigit() and 2 <= int(cameras) <= 16):
        raise RecordingError(
            f"{path}: its metadata record is damaged (its digest does not match): not a recording to replay"
        )


def _damage(recording: Recording, handle: Any, size: int, exc: BaseException) -> str:
    last = recording.messages[-1][1] / 1e9 if recording.messages else None
    after = f"after t = {last:.3f} s" if last is not None else "before any message"
    reason = str(exc) or type(exc).__name__
    return (
        f"{recording.path} is cut short or damaged near byte {handle.tell()} of {size} ({reason}): "
        f"{len(recording.messages)} intact messages, the last {after}"
    )


class Replay(TrackingPipeline):
    """A recording's reports through decoders, synchroniser and tracker again (module docstring).

    `Ps`: track with these projection matrices instead of the recorded calibration."""

    def __init__(self, recording: Recording, Ps: NDArray[np.float64] | None = None) -> None:
        self.recording = recording
        self.Ps_override = None if Ps is None else np.asarray(Ps, dtype=float)
        if self.Ps_override is not None and len(self.Ps_override) != recording.cameras:
            raise RecordingError(
                f"the calibration has {len(self.Ps_override)} cameras, the recording {recording.cameras} remotes"
            )
        first = recording.messages[0][1] / 1e9 if recording.messages else 0.0
        names = [f"replay{c}" for c in range(recording.cameras)]
        super().__init__(names, SimClock(first))
        self.decoders = [ReportDecoder(name=name) for name in names]
        self.end: str | None = recording.end
        self.refused = 0  # steps the rig refused, live and in the replay alike
        self._pending: list[list[IRFrame]] = [[] for _ in names]
        self._next = 0  # the next message to replay
        self._stopped = False

    def connect(self) -> None:
        """Nothing to open: the reports are in the file."""

    def close(self) -> None:
        """Nothing to release."""

    def poll(self) -> None:
        """Replay the messages recorded up to the clock's now."""
        with self._lock:
            limit = round(self.clock.now() * 1e9)
            while not self._stopped and self._next < len(self.recording.messages):
                if self.recording.messages[self._next][1] > limit:
                    break
                self._replay_next()

    def run(
        self, on_frame: Callable[[TrackedFrame], object] | None = None, *, speed: float | None = None
    ) -> list[TrackedFrame]:
        """Replay every message left; the tracked frames in order (each also given to `on_frame`).
        `speed`: pace the replay to the wall clock at this multiple of real time (None: at once)."""
        out: list[TrackedFrame] = []
        t0_log: int | None = None
        t0_wall = time.monotonic()
        while not self._stopped and self._next < len(self.recording.messages):
            log_time = self.recording.messages[self._next][1]
            if speed is not None:
                t0_log = log_time if t0_log is None else t0_log
                wait = (log_time - t0_log) / 1e9 / speed - (time.monotonic() - t0_wall)
                if wait > 0:
                    time.sleep(wait)
            with self._lock:
                tracked = self._replay_next()
            for frame in tracked:
                out.append(frame)
                if on_frame is not None:
                    on_frame(frame)
        return out

    def _replay_next(self) -> list[TrackedFrame]:
        """Replay one message (its time on the clock); the tracked frames it made."""
        topic, log_time, message = self.recording.messages[self._next]
        self._next += 1
        self.clock.sleep(log_time / 1e9 - self.clock.now())
        try:
            tracked = self._step(topic, message)
        except (KeyError, TypeError, ValueError, IndexError) as exc:  # a message that does not fit: damage
            self.end = (
                f"{self.recording.path}: a damaged {topic} message ({type(exc).__name__}: {exc}); replay stopped there"
            )
            tracked = None
        if tracked is None:
            self._stopped = True
            return []
        return tracked

    def _step(self, topic: str, message: dict[str, Any]) -> list[TrackedFrame] | None:
        pending = self._pending
        if topic.endswith("/reports"):
            c = int(message["camera"])
            batch = [(float(t), bytes.fromhex(d)) for t, d in zip(message["t"], message["data"])]
            pending[c] += self.decoders[c].decode(batch)
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
    """Read and replay a recording at once: the replay (its `end`) and the tracked frames."""
    replay = Replay(read_recording(path), Ps)
    return replay, replay.run()
