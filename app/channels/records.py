"""What the tracking process hands a sink's writer process: `FrameRing` records, one `struct` each.

Packed on the rig's thread (`sink_process`), unpacked by the writer process (`sink_serve`). Each
record starts with the ring's record number (`FrameRing`) and its kind:

| kind | fields after (number, kind) | unpacked as |
|---|---|---|
| `DOTS` | camera, the frame's own seq, the sink's seq, t, t_device, dots (4 x 2, NaN: empty slot) | `Dots` (an `IRFrame`) |
| `MARKERS` | the sink's seq, t, n, vectors (1 or 3), ids, position (n x 3) [, velocity, filtered], visible, views | `Markers` (a `TrackedFrame`) |
| `CALIBRATION` | cameras, t, their P (3 x 4 each) | `Calibration` |
| `REPORT` | camera, arrival time, length, the raw HID report's bytes (at most `MAX_REPORT_BYTES`) | `Report` |
| `END` | which event ended (`PROCESSED`, `FLUSHED`, `REPORTS`), camera, now, synced | `End` |
| `ARM` | t, n, q (n), dq (n), base -> link1 (4x4, row major) | `Arm` |
| `SENDER` (back) | the child's Zenoh id and stream (ASCII) | `SenderRecord` |
| `PUT` (back) | a tracked frame's t, when its put returned (`time.monotonic_ns`) | `Put` |

Times are the rig's clock (s); the writer process stamps them in Unix time (`wall_time`). The
sink's seq is the number the tracking process gave the frame (a lost record is a gap a subscriber
sees). Everything is carried bit for bit (float64). A tracked frame's velocity and filtered
estimate travel only in a ring made `with_vectors` (the Zenoh payload holds them; the other sinks'
do not: they come back as NaN); at most `MAX_MARKERS` markers, `MAX_CAMERAS` cameras and
`MAX_JOINTS` joints fit a slot. A reader that needs a rig's events whole (Foxglove's, a
recording's channels) gets each event as its records followed by an `END`. `SENDER` and `PUT` go
back from the Zenoh writer in a second, small ring (`BACK_SLOT_BYTES`); `PUT`'s stamp is
CLOCK_MONOTONIC, the clock of the rig's `SystemClock` on every process of a Linux host.
"""

from __future__ import annotations

import functools
import struct
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from wiithrow.app.channels.frame_ring import FrameRing
from wiithrow.app.network.messages import MarkerRows
from wiithrow.vision.tracked_frame import TrackedFrame
from wiithrow.vision.wiimote.frames import IRFrame
from wiithrow.vision.wiimote.protocol import Button

DOTS, MARKERS, CALIBRATION, REPORT, END, ARM = 1, 2, 4, 5, 6, 16
SENDER, PUT = 21, 22
PROCESSED, FLUSHED, REPORTS = 1, 2, 3
MAX_MARKERS = 16
MAX_REPORT_BYTES = 64
MAX_CAMERAS = 6
MAX_JOINTS = 16
ID_CHARS = 32  # a Zenoh id: 128 bits, at most 32 hex digits
STREAM_CHARS = 16

_KIND = struct.Struct("<QB")
_DOTS = struct.Struct("<QBBqqdd8d")
_REPORT = struct.Struct(f"<QBBdB{MAX_REPORT_BYTES}s")
_END = struct.Struct("<QBBbdq")
_SENDER = struct.Struct(f"<QB{ID_CHARS}s{STREAM_CHARS}s")
_PUT = struct.Struct("<QBdq")


@functools.lru_cache(maxsize=2 * MAX_MARKERS + 2)
def _markers_struct(n: int, vectors: int) -> struct.Struct:
    return struct.Struct(f"<QBqdBB{n}q{3 * vectors * n}d{n}?{n}H")


@functools.lru_cache(maxsize=MAX_CAMERAS + 1)
def _calibration_struct(cameras: int) -> struct.Struct:
    return struct.Struct(f"<QBBd{12 * cameras}d")


@functools.lru_cache(maxsize=MAX_JOINTS + 1)
def _arm_struct(n: int) -> struct.Struct:
    return struct.Struct(f"<QBdB{2 * n}d16d")


def _rounded(size: int) -> int:
    return -(-size // 8) * 8


#: A slot of a ring without vectors (a frame of `MAX_MARKERS` markers: 587 bytes; a calibration of
#: `MAX_CAMERAS`: 594), and of one with them (1,355 bytes), rounded up; the answers' ring (`SENDER`: 57 bytes).
SLOT_BYTES = _rounded(max(_markers_struct(MAX_MARKERS, 1).size, _calibration_struct(MAX_CAMERAS).size))
VECTOR_SLOT_BYTES = _rounded(_markers_struct(MAX_MARKERS, 3).size)
BACK_SLOT_BYTES = _rounded(_SENDER.size)
assert max(_arm_struct(MAX_JOINTS).size, _REPORT.size, _DOTS.size) <= SLOT_BYTES


class TooLarge(ValueError):
    """A frame with more markers, cameras or joints than a record holds."""


# -- packing (the tracking process: one pack_into and a commit each)


def put_dots(ring: FrameRing, camera: int, seq: int, frame: IRFrame) -> None:
    k, offset = ring.slot()
    values = frame.dots.ravel().tolist()
    _DOTS.pack_into(ring.buf, offset, k, DOTS, camera, frame.seq, seq, frame.t, frame.t_device, *values)
    ring.commit()


def put_markers(ring: FrameRing, seq: int, frame: TrackedFrame, *, vectors: bool = False) -> None:
    n = len(frame.ids)
    if n > MAX_MARKERS:
        raise TooLarge(f"a frame of {n} markers: a record holds {MAX_MARKERS}")
    k, offset = ring.slot()
    if vectors:
        values = [
            *frame.position.ravel().tolist(),
            *np.asarray(frame.velocity, dtype=float).ravel().tolist(),
            *np.asarray(frame.filtered, dtype=float).ravel().tolist(),
        ]
    else:
        values = frame.position.ravel().tolist()
    _markers_struct(n, 3 if vectors else 1).pack_into(
        ring.buf,
        offset,
        k,
        MARKERS,
        seq,
        frame.t,
        n,
        3 if vectors else 1,
        *frame.ids.tolist(),
        *values,
        *frame.visible.tolist(),
        *frame.n_views.tolist(),
    )
    ring.commit()


def put_calibration(ring: FrameRing, Ps: NDArray[np.float64], t: float) -> None:
    Ps = np.asarray(Ps, dtype=float)
    if len(Ps) > MAX_CAMERAS:
        raise TooLarge(f"a rig of {len(Ps)} cameras: a record holds {MAX_CAMERAS}")
    k, offset = ring.slot()
    _calibration_struct(len(Ps)).pack_into(ring.buf, offset, k, CALIBRATION, len(Ps), t, *Ps.ravel().tolist())
    ring.commit()


def put_report(ring: FrameRing, camera: int, t: float, data: bytes) -> None:
    if len(data) > MAX_REPORT_BYTES:
        raise TooLarge(f"a report of {len(data)} bytes: a record holds {MAX_REPORT_BYTES}")
    k, offset = ring.slot()
    _REPORT.pack_into(ring.buf, offset, k, REPORT, camera, t, len(data), data)
    ring.commit()


def put_arm(ring: FrameRing, t: float, q: NDArray[np.float64], dq: NDArray[np.float64], T: NDArray[np.float64]) -> None:
    q, dq = np.asarray(q, dtype=float).ravel(), np.asarray(dq, dtype=float).ravel()
    n = len(q)
    if n > MAX_JOINTS or len(dq) != n:
        raise TooLarge(f"an arm of {n} joints ({len(dq)} velocities): a record holds {MAX_JOINTS}")
    k, offset = ring.slot()
    values = [*q.tolist(), *dq.tolist(), *np.asarray(T, dtype=float).ravel().tolist()]
    _arm_struct(n).pack_into(ring.buf, offset, k, ARM, t, n, *values)
    ring.commit()


def put_end(ring: FrameRing, event: int, camera: int = -1, now: float = 0.0, synced: int = 0) -> None:
    k, offset = ring.slot()
    _END.pack_into(ring.buf, offset, k, END, event, camera, now, synced)
    ring.commit()


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


# -- unpacking (the writer process)


@dataclass(frozen=True)
class Dots:
    camera: int
    seq: int
    frame: IRFrame  # t, t_device, seq and dots as handed over (no sizes, buttons or report id)


@dataclass(frozen=True)
class Markers:
    seq: int
    frame: TrackedFrame


@dataclass(frozen=True)
class Calibration:
    Ps: NDArray[np.float64]
    t: float


@dataclass(frozen=True)
class Report:
    camera: int
    t: float
    data: bytes


@dataclass(frozen=True)
class End:
    event: int
    camera: int
    now: float
    synced: int


@dataclass(frozen=True)
class Arm:
    t: float
    q: NDArray[np.float64]
    dq: NDArray[np.float64]
    T: NDArray[np.float64]


@dataclass(frozen=True)
class SenderRecord:
    source: str
    stream: str


@dataclass(frozen=True)
class Put:
    t: float
    at_ns: int


Record = Dots | Markers | Calibration | Report | End | Arm | SenderRecord | Put


def kind_of(record: bytes) -> int:
    """A record's kind (`MARKERS`, `DOTS`, ...), without unpacking the rest."""
    return int(record[8])


def unpack_marker_rows(record: bytes) -> tuple[int, MarkerRows]:
    """A `MARKERS` record's seq and values as plain Python numbers (`messages.MarkerRows`: what a
    Zenoh payload holds; no numpy array built: a writer woken once per poll formats them cold);
    velocity and filtered empty when the ring carries no vectors."""
    if kind_of(record) != MARKERS:
        raise ValueError(f"a record of kind {kind_of(record)}, not markers ({MARKERS})")
    n, vectors = record[8 + 1 + 8 + 8], record[8 + 1 + 8 + 8 + 1]  # after number, kind, seq, t
    fields = _markers_struct(n, vectors).unpack_from(record, 0)
    seq, t, rest = fields[2], fields[3], fields[6:]
    rows = [rest[n + 3 * k : n + 3 * k + 3] for k in range(vectors * n)]
    after = n + 3 * vectors * n
    return seq, MarkerRows(
        t=t,
        ids=rest[:n],
        position=rows[:n],
        velocity=rows[n : 2 * n],
        filtered=rows[2 * n :],
        visible=rest[after : after + n],
        views=rest[after + n : after + 2 * n],
    )


def _tracked_frame(values: MarkerRows) -> TrackedFrame:
    n = len(values.ids)
    position = np.array(values.position, dtype=float).reshape(n, 3)
    unknown = np.full((n, 3), np.nan)
    velocity = np.array(values.velocity, dtype=float).reshape(n, 3) if values.velocity else unknown
    filtered = np.array(values.filtered, dtype=float).reshape(n, 3) if values.filtered else unknown.copy()
    return TrackedFrame(
        values.t,
        np.array(values.ids, dtype=np.int64),
        position,
        velocity,
        filtered,
        np.array(values.visible, dtype=bool),
        np.array(values.views, dtype=np.int64),
    )


def unpack(record: bytes) -> Record:
    """One record as what it carries; ValueError for an unknown kind."""
    kind = _KIND.unpack_from(record, 0)[1]
    if kind == DOTS:
        _, _, camera, frame_seq, seq, t, t_device, *dots = _DOTS.unpack_from(record, 0)
        frame = IRFrame(
            t=t,
            t_device=t_device,
            seq=frame_seq,
            report_id=0,
            dots=np.array(dots, dtype=float).reshape(4, 2),
            sizes=np.full(4, np.nan),
            buttons=Button(0),
        )
        return Dots(camera, seq, frame)
    if kind == MARKERS:
        seq, values = unpack_marker_rows(record)
        return Markers(seq, _tracked_frame(values))
    if kind == CALIBRATION:
        cameras = record[9]
        _, _, _, t, *matrices = _calibration_struct(cameras).unpack_from(record, 0)
        return Calibration(np.array(matrices, dtype=float).reshape(cameras, 3, 4), t)
    if kind == REPORT:
        _, _, camera, t, length, data = _REPORT.unpack_from(record, 0)
        return Report(camera, t, data[:length])
    if kind == END:
        _, _, event, camera, now, synced = _END.unpack_from(record, 0)
        return End(event, camera, now, synced)
    if kind == ARM:
        n = record[8 + 1 + 8]  # after number, kind, t
        _, _, t, _, *joints = _arm_struct(n).unpack_from(record, 0)
        return Arm(t, np.array(joints[:n]), np.array(joints[n : 2 * n]), np.array(joints[2 * n :]).reshape(4, 4))
    if kind == SENDER:
        _, _, source, stream = _SENDER.unpack_from(record, 0)
        return SenderRecord(source.rstrip(b"\0").decode("ascii"), stream.rstrip(b"\0").decode("ascii"))
    if kind == PUT:
        _, _, t, at_ns = _PUT.unpack_from(record, 0)
        return Put(t, at_ns)
    raise ValueError(f"a record of unknown kind {kind}")
