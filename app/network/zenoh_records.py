"""The Zenoh writer process's records: what `ZenohProcessPublisher` packs, and what the child answers.

`frame_records` carries what the ROS 2 and Foxglove writers publish; the Zenoh payloads
(`messages`) carry more, so these records are their own (kinds 11-22, never mixed with
`frame_records`' in one ring), each one `struct`, the ring's record number first (`FrameRing`):

| ring | kind | fields after (number, kind) | unpacked as |
|---|---|---|---|
| to the child | `MARKERS` | seq, t, n, ids, position, velocity, filtered (n x 3 each), visible, views | `Markers`; the writer: `unpack_marker_rows` |
| to the child | `DOTS` | camera, seq, t_device, dots (4 x 2, NaN: empty slot) | `Dots` |
| back | `SENDER` | the child's Zenoh id and stream (ASCII) | `SenderRecord` |
| back | `PUT` | a tracked frame's t, when its put returned (`time.monotonic_ns`) | `Put` |

`seq` is the key's number the tracking process gave the frame (a lost record is a gap a
subscriber sees); everything a payload holds is carried bit for bit (float64), so the child's
JSON is the in-process publisher's. At most `MAX_MARKERS` markers fit a `SLOT_BYTES` slot (the
tracker keeps 4: `vision/tracker.py`'s `max_markers`).

`PUT`'s stamp is CLOCK_MONOTONIC (`time.monotonic_ns`), one clock for every process of a Linux
host: the tracking process's `SystemClock` (`time.monotonic`) reads the same one, so a stamp
taken in the child is a time on the rig's clock when the rig runs on the system clock.
"""

from __future__ import annotations

import functools
import struct
from dataclasses import dataclass

import numpy as np

from wiithrow.app.network.frame_ring import FrameRing
from wiithrow.app.network.messages import MarkerRows
from wiithrow.vision.tracked_frame import TrackedFrame
from wiithrow.vision.wiimote.frames import IRFrame
from wiithrow.vision.wiimote.protocol import Button

MARKERS, DOTS = 11, 12
SENDER, PUT = 21, 22
MAX_MARKERS = 16
#: To the child: a frame of `MAX_MARKERS` markers (1,354 bytes), rounded up to 8.
SLOT_BYTES = 1360
#: Back: the longest answer (`SENDER`: 82 bytes), rounded up.
BACK_SLOT_BYTES = 88
ID_CHARS = 32  # a Zenoh id: 128 bits, at most 32 hex digits
STREAM_CHARS = 16

_KIND = struct.Struct("<QB")
_DOTS = struct.Struct("<QBHqd8d")
_SENDER = struct.Struct(f"<QB{ID_CHARS}s{STREAM_CHARS}s")
_PUT = struct.Struct("<QBdq")


@functools.lru_cache(maxsize=MAX_MARKERS + 1)
def _markers_struct(n: int) -> struct.Struct:
    return struct.Struct(f"<QBqdB{n}q{9 * n}d{n}?{n}H")


assert _markers_struct(MAX_MARKERS).size <= SLOT_BYTES and _SENDER.size <= BACK_SLOT_BYTES


class TooLarge(ValueError):
    """A frame with more markers than a record holds."""


# -- the tracking process: one pack_into and a commit each


def put_markers(ring: FrameRing, seq: int, frame: TrackedFrame) -> None:
    n = len(frame.ids)
    if n > MAX_MARKERS:
        raise TooLarge(f"a frame of {n} markers: a record holds {MAX_MARKERS}")
    k, offset = ring.slot()
    _markers_struct(n).pack_into(
        ring.buf,
        offset,
        k,
        MARKERS,
        seq,
        frame.t,
        n,
        *frame.ids.tolist(),
        *np.asarray(frame.position, dtype=float).ravel().tolist(),
        *np.asarray(frame.velocity, dtype=float).ravel().tolist(),
        *np.asarray(frame.filtered, dtype=float).ravel().tolist(),
        *frame.visible.tolist(),
        *frame.n_views.tolist(),
    )
    ring.commit()


def put_dots(ring: FrameRing, camera: int, seq: int, frame: IRFrame) -> None:
    k, offset = ring.slot()
    _DOTS.pack_into(ring.buf, offset, k, DOTS, camera, seq, frame.t_device, *frame.dots.ravel().tolist())
    ring.commit()


# -- the child: what it answers


def put_sender(ring: FrameRing, source: str, stream: str) -> None:
    if len(source) > ID_CHARS or len(stream) > STREAM_CHARS:
        raise ValueError(f"a Zenoh id of {len(source)} characters or a stream of {len(stream)}: too long a record")
    k, offset = ring.slot()
    _SENDER.pack_into(ring.buf, offset, k, SENDER, source.encode("ascii"), stream.encode("ascii"))
    ring.commit()


def put_put(ring: FrameRing, t: float, at_ns: int) -> None:
    k, offset = ring.slot()
    _PUT.pack_into(ring.buf, offset, k, PUT, t, at_ns)
    ring.commit()


@dataclass(frozen=True)
class Markers:
    seq: int
    frame: TrackedFrame


@dataclass(frozen=True)
class Dots:
    camera: int
    seq: int
    frame: IRFrame  # t_device and dots as handed over (t = t_device; no sizes, buttons or report id)


@dataclass(frozen=True)
class SenderRecord:
    source: str
    stream: str


@dataclass(frozen=True)
class Put:
    t: float
    at_ns: int


Record = Markers | Dots | SenderRecord | Put


def kind_of(record: bytes) -> int:
    """A record's kind (`MARKERS`, `DOTS`, ...), without unpacking the rest."""
    return int(record[8])


def unpack_marker_rows(record: bytes) -> tuple[int, MarkerRows]:
    """A `MARKERS` record's seq and values as plain Python numbers (what its JSON payload holds:
    `messages.MarkerRows`), no numpy array built: the Zenoh writer's path."""
    if kind_of(record) != MARKERS:
        raise ValueError(f"a record of kind {kind_of(record)}, not markers ({MARKERS})")
    n = record[8 + 1 + 8 + 8]  # after number, kind, seq, t
    fields = _markers_struct(n).unpack_from(record, 0)
    seq, t, rest = fields[2], fields[3], fields[5:]
    xyz = [rest[n + 3 * k : n + 3 * k + 3] for k in range(3 * n)]  # position, velocity, filtered rows
    return seq, MarkerRows(
        t=t,
        ids=rest[:n],
        position=xyz[:n],
        velocity=xyz[n : 2 * n],
        filtered=xyz[2 * n :],
        visible=rest[10 * n : 11 * n],
        views=rest[11 * n : 12 * n],
    )


def unpack(record: bytes) -> Record:
    """One record as what it carries; ValueError for a kind of no Zenoh record."""
    kind = _KIND.unpack_from(record, 0)[1]
    if kind == MARKERS:
        seq, rows = unpack_marker_rows(record)
        vectors = np.array([rows.position, rows.velocity, rows.filtered], dtype=float).reshape(3, -1, 3)
        frame = TrackedFrame(
            t=rows.t,
            ids=np.array(rows.ids, dtype=np.int64),
            position=vectors[0],
            velocity=vectors[1],
            filtered=vectors[2],
            visible=np.array(rows.visible, dtype=bool),
            n_views=np.array(rows.views, dtype=np.int64),
        )
        return Markers(seq, frame)
    if kind == DOTS:
        _, _, camera, seq, t_device, *dots = _DOTS.unpack_from(record, 0)
        camera_frame = IRFrame(
            t=t_device,
            t_device=t_device,
            seq=seq,
            report_id=0,
            dots=np.array(dots, dtype=float).reshape(4, 2),
            sizes=np.full(4, np.nan),
            buttons=Button(0),
        )
        return Dots(camera, seq, camera_frame)
    if kind == SENDER:
        _, _, source, stream = _SENDER.unpack_from(record, 0)
        return SenderRecord(source.rstrip(b"\0").decode("ascii"), stream.rstrip(b"\0").decode("ascii"))
    if kind == PUT:
        _, _, t, at_ns = _PUT.unpack_from(record, 0)
        return Put(t, at_ns)
    raise ValueError(f"a record of kind {kind}: no Zenoh record")
