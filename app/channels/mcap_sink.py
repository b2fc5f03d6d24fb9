"""`McapSink`: the channels' JSON messages written to an MCAP file as they come, losing at most the
last second.

Every message is JSON (MCAP message encoding "json") with its channel's JSON Schema
(`registry`, `json_schemas`), so Foxglove and the `mcap` tools read the file without a plugin; its
log time is its Unix time (`wall_time`). The header names the caller's profile, a metadata record
holds what the caller says (the recording's format: `wiithrow.app.recording.channels`), and a
channel is registered with the first message of its topic.

Losing nothing it had: messages go into compressed chunks that are closed and flushed to the file
at least every `flush_every_s` (of the messages' time or of wall time; a thread of its own,
`wiithrow-recording`, flushes what waits when nothing new comes), so a writer killed with SIGKILL
leaves a file whose complete chunks any MCAP reader reads. A write that fails (a full disk) or a
file that vanished (its folder removed) stops the sink, once, with one line to `on_error`; the
caller goes on: `write` never raises.
"""

from __future__ import annotations

import os
import threading
import time
from collections.abc import Callable
from pathlib import Path
from typing import IO, Any

from mcap.writer import CompressionType, Writer

from wiithrow.app.channels import json_schemas
from wiithrow.app.channels.json_messages import encode
from wiithrow.app.channels.registry import channel_of
from wiithrow.app.channels.wall_time import NS_PER_S

FLUSH_EVERY_S = 1.0
CHUNK_BYTES = 256 * 1024


class McapSink:
    """An MCAP file at `path` for the channels' JSON messages (module docstring): `open`, `write`
    as they come, `close`. `error` holds the one line that stopped a failed sink."""

    def __init__(
        self,
        path: str | os.PathLike[str],
        *,
        on_error: Callable[[str], object],
        flush_every_s: float = FLUSH_EVERY_S,
        chunk_bytes: int = CHUNK_BYTES,
    ) -> None:
        self.path = Path(path)
        self.on_error = on_error
        self.flush_every_s = flush_every_s
        self.chunk_bytes = chunk_bytes
        self.error: str | None = None
        self.messages = 0
        self.on_stop: Callable[[], object] = lambda: None  # what the caller undoes when a failure stops the sink
        self._file: IO[bytes] | None = None
        self._writer: Writer | None = None
        self._channels: dict[str, int] = {}
        self._schemas: dict[str, int] = {}
        self._lock = threading.Lock()
        self._last_flush_wall = 0.0
        self._last_flush_ns = 0
        self._unflushed = 0
        self._stop = threading.Event()
        self._flusher: threading.Thread | None = None

    @property
    def active(self) -> bool:
        return self._writer is not None

    def open(
        self,
        profile: str,
        library: str,
        metadata: dict[str, dict[str, str]],
        attachments: list[tuple[str, str, bytes]],
        stamp_ns: int,
    ) -> None:
        """Create the file: its header, `metadata` (name -> entries) and `attachments` (name, media
        type, data) at `stamp_ns`; OSError when it cannot be created (the file closed)."""
        try:
            self.path.parent.mkdir(parents=True, exist_ok=True)
            self._file = open(self.path, "wb")  # noqa: SIM115 - kept open for the whole run
            writer = Writer(self._file, chunk_size=self.chunk_bytes, compression=CompressionType.ZSTD)
            writer.start(profile=profile, library=library)
            for name, entries in metadata.items():
                writer.add_metadata(name, entries)
            for name, media_type, data in attachments:
                writer.add_attachment(stamp_ns, stamp_ns, name, media_type, data)
            self._writer = writer
            self._file.flush()
        except OSError:
            self._close_file()
            raise
        self._last_flush_wall, self._last_flush_ns = time.monotonic(), stamp_ns
        # flushes what waits when nothing new comes (a silent rig): the last second is never held longer
        self._flusher = threading.Thread(target=self._flush_loop, name="wiithrow-recording", daemon=True)
        self._flusher.start()

    def write(self, topic: str, stamp_ns: int, message: dict[str, Any]) -> None:
        """One message of `topic` at `stamp_ns` (Unix ns); never raises (a failure stops the sink)."""
        with self._lock:
            writer = self._writer
            if writer is None:
                return
            try:
                channel = self._channels.get(topic)
                if channel is None:
                    channel = self._channel(writer, topic)
                writer.add_message(channel, stamp_ns, encode(message), stamp_ns, self.messages)
                self.messages += 1
                self._unflushed += 1
                wall = time.monotonic()
                if (
                    wall - self._last_flush_wall >= self.flush_every_s
                    or stamp_ns - self._last_flush_ns >= self.flush_every_s * NS_PER_S
                ):
                    self._flush(writer, wall, stamp_ns)
            except (OSError, ValueError, TypeError) as exc:  # never into the caller: the sink stops
                self._fail(exc)

    def _channel(self, writer: Writer, topic: str) -> int:
        channel = channel_of(topic)
        if channel is None:
            raise ValueError(f"no channel {topic!r}")
        schema = self._schemas.get(channel.schema)
        if schema is None:
            data = json_schemas.schema_bytes(channel.schema)
            schema = self._schemas[channel.schema] = writer.register_schema(channel.schema, "jsonschema", data)
        self._channels[topic] = writer.register_channel(topic, "json", schema)
        return self._channels[topic]

    def close(self) -> None:
        """Finish the file (its summary and index); harmless when stopped."""
        self._stop.set()
        if self._flusher is not None and self._flusher is not threading.current_thread():
            self._flusher.join(timeout=2.0)
        with self._lock:
            writer, self._writer = self._writer, None
            if writer is not None:
                try:
                    writer.finish()
                except (OSError, ValueError) as exc:
                    self._report(f"recording stopped: cannot finish {self.path}: {exc}")
            self._close_file()

    def _flush_loop(self) -> None:
        while not self._stop.wait(self.flush_every_s / 2):
            with self._lock:
                writer = self._writer
                if writer is None:
                    return
                wall = time.monotonic()
                if self._unflushed and wall - self._last_flush_wall >= self.flush_every_s:
                    try:
                        self._flush(writer, wall, self._last_flush_ns)
                    except Exception as exc:  # a full disk, a vanished file, or a bug: one line, the caller goes on
                        self._fail(exc)

    def _flush(self, writer: Writer, wall: float, stamp_ns: int) -> None:
        """Close the chunk and hand it to the OS; check that the file is still there."""
        writer.flush()
        self._unflushed = 0
        self._last_flush_wall, self._last_flush_ns = wall, stamp_ns
        if self._file is not None and os.fstat(self._file.fileno()).st_nlink == 0:
            raise OSError(f"{self.path} vanished (its folder was removed or the file deleted)")

    def _fail(self, exc: Exception) -> None:
        reason = exc.strerror if isinstance(exc, OSError) and exc.strerror else str(exc) or type(exc).__name__
        self._writer = None
        self.on_stop()
        self._close_file()
        self._report(f"recording stopped: cannot write {self.path}: {reason}; tracking goes on")

    def _report(self, message: str) -> None:
        self.error = message
        try:
            self.on_error(message)
        except Exception:
            pass

    def _close_file(self) -> None:
        f, self._file = self._file, None
        if f is not None:
            try:
                f.close()
            except OSError:
                pass
