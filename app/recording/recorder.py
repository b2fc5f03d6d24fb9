"""`Recorder`: one run written to an MCAP file as it happens, losing at most the last second.

It listens to a local rig's events (`RigStream.subscribe`, `wiithrow.app.rig.events`: the raw
reports its drivers read, each camera's frames processed, each flush, each calibration), so it
sees every raw report with its receive time, every camera frame, every step of the rig and every
tracked frame, in the order they happen, and writes each as its channels' messages
(`wiithrow.app.channels.rig_messages`) to an MCAP file (`wiithrow.app.channels.mcap_sink`: a
chunk flushed at least every second; a write that fails stops the recording, once, with one line
to `on_error`, stderr by default, and the tracking goes on: the recorder never raises into the
rig). A session adds its arm and throws (`SessionRecorder`). The file's format: `channels`.

Times: the messages' `t` fields are the rig's clock, their log times its Unix time
(`wiithrow.app.channels.wall_time`: the clock mapped once, `unix_offset_ns` in the metadata).

A recording starts from a fresh synchroniser and tracker (`RigStream.restart`: track ids restart
when a recording starts mid-run), the state its replay starts from, so that the replay gives the
recorded markers exactly.
"""

from __future__ import annotations

import os
import sys
from collections.abc import Callable
from datetime import UTC, datetime
from typing import TYPE_CHECKING, Any

import wiithrow
from wiithrow.app.channels.mcap_sink import CHUNK_BYTES, FLUSH_EVERY_S, McapSink
from wiithrow.app.channels.rig_messages import RigMessages
from wiithrow.app.channels.wall_time import wall_time
from wiithrow.app.recording import channels as ch
from wiithrow.app.recording.channels import RecordingError
from wiithrow.app.rig.events import CalibrationChanged, RigEvent
from wiithrow.clock import Clock
from wiithrow.listeners import Unsubscribe

if TYPE_CHECKING:  # (the tracker: scipy's optimisers and the numba kernels, which a writer process never calls)
    from wiithrow.app.rig.pipeline import TrackingPipeline


def _stderr(message: str) -> None:
    print(f"wiithrow: {message}", file=sys.stderr)


class Recorder:
    """Writes what a rig (and optionally a session) does to `path` (see the module docstring).

    `start(rig)` opens the file and begins; `close()` ends it with MCAP's summary. `error` holds
    the one line that stopped a failed recording (None while all is well)."""

    def __init__(
        self,
        path: str | os.PathLike[str],
        clock: Clock,
        *,
        frame_id: str = "link1",
        calibration_text: str | None = None,
        on_error: Callable[[str], object] = _stderr,
        flush_every_s: float = FLUSH_EVERY_S,
        chunk_bytes: int = CHUNK_BYTES,
        extra_metadata: dict[str, str] | None = None,
    ) -> None:
        self.clock = clock
        self.frame_id = frame_id
        self.calibration_text = calibration_text
        self.extra_metadata = dict(extra_metadata or {})
        self.wall = wall_time(clock)
        self.sink = McapSink(path, on_error=on_error, flush_every_s=flush_every_s, chunk_bytes=chunk_bytes)
        self.sink.on_stop = lambda: self._detach(wait_for_rig=False)
        self.path = self.sink.path
        self.rig_messages = RigMessages(self._write, self.wall, frame_id)
        self._rig: TrackingPipeline | None = None
        self._unsubscribe: Unsubscribe | None = None

    @property
    def active(self) -> bool:
        return self.sink.active

    @property
    def error(self) -> str | None:
        return self.sink.error

    @property
    def messages(self) -> int:
        return self.sink.messages

    # ------------------------------------------------------------------ lifecycle

    def start(self, rig: TrackingPipeline) -> None:
        """Open the file, write the header, the format version and the calibration, and listen to
        `rig`, a local rig (`RigStream`) or a pipeline its decoders' raw reports reach (subscribe
        before `rig.connect()` to keep the remotes' start-up reports too).
        `RecordingError` when the file cannot be created."""
        metadata = {
            "format_version": str(ch.FORMAT_VERSION),
            "wiithrow_version": wiithrow.__version__,
            "cameras": str(len(rig.camera_names)),
            "camera_names": ",".join(rig.camera_names),
            "frame_id": self.frame_id,
            "clock": type(self.clock).__name__,
            "time_base": "unix",
            "unix_offset_ns": str(self.wall.offset_ns),
            "started_utc": datetime.now(UTC).isoformat(timespec="seconds"),
            **self.extra_metadata,
        }
        attachments = []
        if self.calibration_text is not None:
            attachments.append((ch.CALIBRATION_ATTACHMENT, "application/json", self.calibration_text.encode()))
        try:
            self.sink.open(
                ch.PROFILE,
                f"wiithrow {wiithrow.__version__}",
                {ch.METADATA_NAME: metadata | {"digest": ch.digest(metadata)}},
                attachments,
                self.wall.stamp_ns(self.clock.now()),
            )
        except OSError as exc:
            raise RecordingError(f"cannot record to {self.path}: {exc.strerror or exc}") from None
        self._rig = rig
        with rig.lock:  # between two polls: the file starts from a state a replay starts from
            rig.restart()
            if rig.Ps is not None:
                self.rig_messages.calibrated(rig.Ps, self.clock.now())
            self._unsubscribe = rig.subscribe(self._event_of_rig)

    def close(self) -> None:
        """Stop observing and finish the file (its summary and index); harmless when stopped."""
        self._detach()
        self.sink.close()

    def __enter__(self) -> Recorder:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def _detach(self, *, wait_for_rig: bool = True) -> None:
        """Stop observing: between two polls, or at once after a failure (which may come from
        another thread holding the sink's lock: waiting for the rig could deadlock, and without a
        writer a call in flight writes nothing)."""
        rig, self._rig = self._rig, None
        unsubscribe, self._unsubscribe = self._unsubscribe, None
        if rig is not None and unsubscribe is not None:
            if wait_for_rig:
                rig.lock.acquire()
            try:
                unsubscribe()
            finally:
                if wait_for_rig:
                    rig.lock.release()

    # ------------------------------------------------------------------ what the rig tells

    def _event_of_rig(self, event: RigEvent) -> None:
        """One event of the rig (called under its lock, in order; never raises: see `McapSink.write`)."""
        self.rig_messages.event(event, self.clock.now() if isinstance(event, CalibrationChanged) else 0.0)

    def mark_start(self, t: float) -> None:
        """The command started tracking at `t` (the rig's clock): `/rig/start`, what a replay's
        rows count their `t` from."""
        self.rig_messages.mark_start(t)

    def _write(self, topic: str, stamp_ns: int, message: dict[str, Any]) -> None:
        self.sink.write(topic, stamp_ns, message)
