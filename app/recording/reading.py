"""Reading a recording: its leading records at once, its messages streamed, within stated limits.

`read_recording` reads what a recording starts with (the header, the `wiithrow` metadata record
with its format version and digest, the calibration attachment: `Recorder` writes them before any
chunk) and refuses a file that is not MCAP, not a wiithrow recording, damaged there, or from a
newer format version (`RecordingError`, one line). It keeps no message: `Recording.messages()`
is one pass over the file in file order (`MessageStream`, the `mcap` package's `StreamReader`
underneath), as many passes as a caller needs, each holding one chunk at a time, so memory is
bounded by the chunk size, not by the file. A pass may start at a chunk an earlier pass found
(`MessageStream.resume_point`, a `Resume`: the chunk's offset and the channels defined before it),
so a player can seek without reading the file from its start.

A pass reads as far as the file is intact: a file cut short (a recorder killed) or corrupt in the
middle (a bad CRC, bad compression, a record that does not parse) ends the pass there, keeping
every message before the damage, and `MessageStream.end` says where it ends.

What a file may ask for is bounded before it is spent (a decompression bomb is refused in one line
before the machine's memory is, `RecordingError`, not as damage):

- a chunk that declares more than `MAX_CHUNK_BYTES` decompressed is refused before decompressing;
- a chunk is decompressed in pieces of `_PIECE` bytes (zstd, as `Recorder` writes, or lz4, which
  the `mcap` package reads too): one that turns out to expand beyond `MAX_CHUNK_BYTES` is refused
  at that point, and one that expands to more (or less) than it declares, within the limit, is
  damage;
- no record, nor any field a record declares (an attachment's data, a chunk's compressed
  data), may be longer than `MAX_RECORD_BYTES`: a read that asks for more is refused before it is
  made.
"""

from __future__ import annotations

import io
import os
import zlib
from collections.abc import Collection, Generator, Iterator
from dataclasses import dataclass, field
from pathlib import Path
from types import TracebackType
from typing import IO, Any, NamedTuple

from mcap.data_stream import ReadDataStream
from mcap.exceptions import RecordLengthLimitExceeded
from mcap.opcode import Opcode
from mcap.records import Attachment, Channel, Chunk, Footer, Header, Message, Metadata
from mcap.stream_reader import StreamReader

from wiithrow.app.channels.wall_time import UNMAPPED, WallTime
from wiithrow.app.recording import channels as ch
from wiithrow.app.recording.channels import RecordingError
from wiithrow.vision.files import loads_json

MAGIC = b"\x89MCAP0\r\n"

#: The most a chunk may hold decompressed: 64 MiB. `Recorder` closes its chunks at 256 KiB
#: (`CHUNK_BYTES`) or every second, whichever comes first, and other MCAP writers use a few MiB
#: (the `mcap` package's default is 1 MiB), so 64 MiB leaves every real file 16 times the room it
#: needs, while what one chunk can cost a replay (its decompressed bytes, held once, about 0.1 s
#: of zstd) stays a small part of a small machine's memory and time.
MAX_CHUNK_BYTES = 64 * 2**20

#: The most one record of the file (or a field it declares) may be: a chunk record is its
#: compressed data and some 50 bytes of header, and compressed data is at most its decompressed
#: size plus the compressor's framing, so a chunk within `MAX_CHUNK_BYTES` fits.
MAX_RECORD_BYTES = MAX_CHUNK_BYTES + 2**20

#: A message record's fields before its data: channel id (2), sequence (4), log and publish times (8 each).
_MESSAGE_HEADER = 22

#: How much is decompressed at a time: the bound on what a chunk beyond the limit costs to find out.
_PIECE = 2**20


class RecordedMessage(NamedTuple):
    """One message as the file holds it: topic, log time (ns) and its JSON text, not parsed."""

    topic: str
    log_time: int
    data: bytes

    def json(self) -> Any:
        """The message parsed (`loads_json`: nested too deep is one line, `FileFormatError`)."""
        return loads_json(self.data, f"a {self.topic} message at t = {self.log_time / 1e9:.3f} s")


@dataclass
class Recording:
    """What a recording starts with (`read_recording`); its messages are read by `messages()`."""

    path: Path
    metadata: dict[str, str]
    attachments: dict[str, bytes] = field(default_factory=dict)

    @property
    def cameras(self) -> int:
        return int(self.metadata.get("cameras", "2"))

    @property
    def frame_id(self) -> str:
        return self.metadata.get("frame_id", "link1")

    @property
    def camera_names(self) -> list[str]:
        """The rig's camera names (a recording of format 1: `camera_c`)."""
        names = self.metadata.get("camera_names", "")
        return names.split(",") if names else [f"camera_{c}" for c in range(self.cameras)]

    @property
    def wall(self) -> WallTime:
        """The rig's clock mapped to the log times (format 1: the log times are the rig's clock)."""
        try:
            return WallTime(int(self.metadata.get("unix_offset_ns", "0")))
        except ValueError:
            return UNMAPPED

    def messages(self, topics: Collection[str] | None = None, *, resume: Resume | None = None) -> MessageStream:
        """A new pass over the file's messages (of `topics` only, when given), in file order: from
        the start, or from `resume` (a `MessageStream.resume_point` of an earlier pass)."""
        return MessageStream(self.path, topics, resume=resume)

    def topic(self, name: str) -> Iterator[Any]:
        """The parsed messages of one topic, in order: a pass over the file, as far as it is intact."""
        with self.messages([name]) as stream:
            for message in stream:
                yield message.json()


def read_recording(path: str | os.PathLike[str]) -> Recording:
    """A recording's leading records (see the module docstring); `RecordingError` when refused."""
    path = Path(path)
    handle = _open(path)
    with handle:
        if handle.read(len(MAGIC)) != MAGIC:
            raise RecordingError(f"{path} is not an MCAP file")
        handle.seek(0)
        recording = Recording(path, {})
        try:
            for record in _reader(handle, path, crcs=False).records:
                if isinstance(record, Header) and record.profile != ch.PROFILE:
                    raise RecordingError(f"{path} is not a wiithrow recording (MCAP profile {record.profile!r})")
                if isinstance(record, Metadata) and record.name == ch.METADATA_NAME and not recording.metadata:
                    _check_version(path, record.metadata)
                    _check_cameras(path, record.metadata)
                    recording.metadata = dict(record.metadata)
                elif isinstance(record, Attachment) and record.name == ch.CALIBRATION_ATTACHMENT:
                    recording.attachments[record.name] = bytes(record.data)
                elif isinstance(record, Chunk | Message | Footer):
                    break  # the messages begin: what comes before them is all read_recording needs
        except RecordingError:
            raise
        except Exception:  # damage among the leading records: refused below unless the metadata was read
            pass
        if not recording.metadata:
            raise RecordingError(f"{path} is not a wiithrow recording (no {ch.METADATA_NAME!r} metadata at its start)")
        return recording


def _open(path: Path) -> IO[bytes]:
    try:
        return open(path, "rb")
    except OSError as exc:
        raise RecordingError(f"cannot read {path}: {exc.strerror or exc}") from None


class _BoundedReads:
    """A file whose every read is at most `MAX_RECORD_BYTES`: a field declaring more is refused
    before the read allocates it (the `mcap` records read the lengths they are told)."""

    def __init__(self, handle: IO[bytes], path: Path) -> None:
        self.handle = handle
        self.path = path

    def read(self, size: int = -1) -> bytes:
        if size < 0:  # a message record shorter than its own header: damage, not a read of the rest
            raise _Damage(f"a record near byte {self.handle.tell()} shorter than its header")
        if size > MAX_RECORD_BYTES:
            raise RecordingError(
                f"{self.path}: a record near byte {self.handle.tell()} declares {_size(size)}, over the limit of "
                f"{_size(MAX_RECORD_BYTES)}: not a recording to replay"
            )
        return self.handle.read(size)


def _reader(handle: IO[bytes], path: Path, *, crcs: bool, mid_file: bool = False) -> StreamReader:
    return StreamReader(
        _BoundedReads(handle, path),  # type: ignore[arg-type]  # read() is all StreamReader uses
        skip_magic=mid_file,  # from a record's start: no leading magic (nor the data section's CRC)
        emit_chunks=True,
        validate_crcs=crcs,
        record_size_limit=MAX_RECORD_BYTES,
    )


def _size(n: int) -> str:
    return f"{n / 2**20:.0f} MiB" if n >= 2**20 else f"{n} bytes"


@dataclass(frozen=True)
class Resume:
    """Where a pass may start again: the byte offset of a chunk and the channels (id: topic)
    defined before it (a chunk's messages may use channels an earlier chunk defined)."""

    offset: int
    channels: dict[int, str]


class MessageStream:
    """One pass over a recording's messages in file order, as far as the file is intact (the module
    docstring): an iterator of `RecordedMessage`s that holds one chunk at a time. `end` says where a
    damaged file ends once the pass has reached it (None: intact so far, or complete); a chunk or
    record beyond the limits raises `RecordingError`. Close it (or use it in a `with`) to release
    the file before the end. `resume_point`: where the chunk of the last message read begins (None:
    the file's start), for a later pass to start there (`resume`: its counts and `end`'s then count
    from there)."""

    def __init__(self, path: Path, topics: Collection[str] | None = None, *, resume: Resume | None = None) -> None:
        self.path = path
        self.resume = resume
        self.resume_point: Resume | None = resume
        self.topics = None if topics is None else frozenset(topics)
        self.end: str | None = None
        self.count = 0  # messages read (of every topic)
        self.last_time: int | None = None  # the last one's log time (ns)
        self._handle = _open(path)
        self._size = os.fstat(self._handle.fileno()).st_size
        self._messages = self._read()

    def __iter__(self) -> MessageStream:
        return self

    def __next__(self) -> RecordedMessage:
        return next(self._messages)

    def close(self) -> None:
        self._messages.close()
        self._handle.close()

    def __enter__(self) -> MessageStream:
        return self

    def __exit__(self, kind: type[BaseException] | None, exc: BaseException | None, tb: TracebackType | None) -> None:
        self.close()

    def _read(self) -> Generator[RecordedMessage, None, None]:
        try:
            channels: dict[int, str] = {}
            if self.resume is not None:
                channels = dict(self.resume.channels)
                self._handle.seek(self.resume.offset)
            records = _reader(self._handle, self.path, crcs=True, mid_file=self.resume is not None).records
            complete = False
            while True:
                at = self._handle.tell()
                try:
                    record = next(records)
                except StopIteration:  # after the footer and the closing magic
                    break
                except RecordLengthLimitExceeded as exc:
                    raise RecordingError(
                        f"{self.path}: the record at byte {at} is longer than the limit of {_size(MAX_RECORD_BYTES)} "
                        f"({exc}): not a recording to replay"
                    ) from None
                except RecordingError:
                    raise
                except Exception as exc:  # any damage (truncation, a bad CRC, a bad closing magic) ends the pass
                    self.end = self._damage(exc)
                    return
                try:
                    if isinstance(record, Chunk):
                        self.resume_point = Resume(at, dict(channels))
                        for inner in _chunk_records(chunk_content(record, at, self.path)):
                            yield from self._record(inner, channels)
                    elif isinstance(record, Footer):
                        complete = True
                    else:
                        yield from self._record(record, channels)
                except RecordingError:
                    raise
                except Exception as exc:  # a chunk that does not decompress or parse, a message of no channel
                    self.end = self._damage(exc)
                    return
            if not complete:
                self.end = self._damage(EOFError("no footer"))
        finally:
            self._handle.close()

    def _record(self, record: Any, channels: dict[int, str]) -> Iterator[RecordedMessage]:
        if isinstance(record, Channel):
            channels[record.id] = record.topic
        elif isinstance(record, Message):
            topic = channels.get(record.channel_id)
            if topic is None:
                raise _Damage(f"a message of channel {record.channel_id}, which no channel record before it defines")
            self.count += 1
            self.last_time = record.log_time
            if self.topics is None or topic in self.topics:
                yield RecordedMessage(topic, record.log_time, bytes(record.data))

    def _damage(self, exc: BaseException) -> str:
        last = self.last_time / 1e9 if self.last_time is not None else None
        after = f"after t = {last:.3f} s" if last is not None else "before any message"
        reason = str(exc) or type(exc).__name__
        return (
            f"{self.path} is cut short or damaged near byte {self._handle.tell()} of {self._size} ({reason}): "
            f"{self.count} intact messages, the last {after}"
        )


class _Damage(Exception):
    """A record that does not fit (its reason): the intact part ends before it."""


def chunk_content(chunk: Chunk, at: int, path: Path) -> bytes:
    """A chunk's records, decompressed within `MAX_CHUNK_BYTES` and checked against its CRC.

    `RecordingError` for a chunk that declares or expands to more than the limit (found while
    decompressing, a piece at a time); `_Damage` for one that expands to another size than it
    declares, fails its CRC or does not decompress."""
    declared = chunk.uncompressed_size
    if declared > MAX_CHUNK_BYTES:
        raise RecordingError(
            f"{path}: the chunk at byte {at} declares {_size(declared)} decompressed, over the limit of "
            f"{_size(MAX_CHUNK_BYTES)}: not a recording to replay"
        )
    content = bytearray()
    total = 0
    for piece in _decompressed(chunk, path):
        total += len(piece)
        if total > MAX_CHUNK_BYTES:
            raise RecordingError(
                f"{path}: the chunk at byte {at} expands to more than {_size(MAX_CHUNK_BYTES)} (the limit) "
                f"though it declares {_size(declared)}: not a recording to replay"
            )
        if len(content) < declared:
            content += piece[: declared - len(content)]
    if total != declared:
        raise _Damage(f"the chunk at byte {at} expands to {total} bytes, not the {declared} it declares")
    if chunk.uncompressed_crc != 0 and zlib.crc32(content) != chunk.uncompressed_crc:
        raise _Damage(f"the chunk at byte {at} fails its CRC")
    return bytes(content)


def _decompressed(chunk: Chunk, path: Path) -> Iterator[bytes]:
    """A chunk's data decompressed `_PIECE` bytes at a time (never more at once)."""
    if chunk.compression == "":
        data = chunk.data
        for start in range(0, len(data), _PIECE):
            yield data[start : start + _PIECE]
    elif chunk.compression == "zstd":
        import zstandard

        reader = zstandard.ZstdDecompressor().stream_reader(io.BytesIO(chunk.data), read_across_frames=False)
        while piece := reader.read(_PIECE):
            yield piece
    elif chunk.compression == "lz4":
        import lz4.frame  # type: ignore[import-untyped]  # the mcap package's dependency: it reads lz4 chunks

        decompressor = lz4.frame.LZ4FrameDecompressor()
        piece = decompressor.decompress(chunk.data, max_length=_PIECE)
        yield piece
        while not decompressor.eof and not decompressor.needs_input:
            yield decompressor.decompress(b"", max_length=_PIECE)
    else:
        raise RecordingError(f"{path}: chunks compressed with {chunk.compression!r}, which wiithrow cannot read")


def _chunk_records(content: bytes) -> Iterator[Any]:
    """The channels and messages of a chunk's records, one at a time (not all of them parsed at once)."""
    data = ReadDataStream(io.BytesIO(content))
    while data.count < len(content):
        opcode = data.read1()
        length = data.read8()
        if length > len(content) - data.count:
            raise _Damage("a record in a chunk runs past the chunk's end")
        if opcode == Opcode.CHANNEL:
            yield Channel.read(data)
        elif opcode == Opcode.MESSAGE:
            if length < _MESSAGE_HEADER:
                raise _Damage("a message in a chunk shorter than its header")
            yield Message.read(data, length)
        else:
            data.read(length)


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


__all__ = [
    "MAX_CHUNK_BYTES",
    "MAX_RECORD_BYTES",
    "MessageStream",
    "RecordedMessage",
    "Recording",
    "Resume",
    "read_recording",
]
