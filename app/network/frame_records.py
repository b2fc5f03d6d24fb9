"""A rig's frames as `FrameRing` records: packed by the tracking process, unpacked by a writer process.

One record per thing handed over, each one `struct` (cached per marker count), the record's ring
number first (`FrameRing`):

| kind | fields after (number, kind) | unpacked as |
|---|---|---|
| `DOTS` | camera, frame seq, t, t_device, stamp_ns, dots (4 x 2, NaN: empty slot) | `Dots` (an `IRFrame`) |
| `MARKERS` | publisher seq, t, stamp_ns, n, ids, positions (n x 3), visible, views | `Markers` (a `TrackedFrame`) |
| `POSE` | stamp_ns, a 4x4 transform (row major) | `Pose` |
| `CALIBRATION` | cameras, their P (3 x 4 each) | `Calibration` |
| `REPORT` | camera, arrival time, length, the raw HID report's bytes (at most `MAX_REPORT_BYTES`) | `Report` |
| `END` | which event ended (`PROCESSED`, `FLUSHED`, `REPORTS`, `CALIBRATED`), camera, now, synced | `End` |
| `ARM` | t (the rig's clock), n, q (n), dq (n), base -> link1 (4x4, row major) | `Arm` |

A reader that needs a rig's events whole (a recording's channels: Foxglove) gets each event as
its records followed by an `END`. `ARM` is a session's arm sampled as its recorder samples it
(`SessionRecorder`: the joints and base -> link1 when a camera's frames were processed), a record of
its own after that event's `END`; at most `MAX_JOINTS` joints.

`stamp_ns` is the Unix time taken when the frame was handed over (what the messages' stamps
say). A TrackedFrame's velocity and filtered estimate are not carried (no writer publishes them:
they come back as NaN); at most `MAX_MARKERS` markers (the tracker's default keeps 4) and
`MAX_CAMERAS` cameras fit a slot of `SLOT_BYTES`.
"""

from __future__ import annotations

import functools
import struct
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from wiithrow.app.network.frame_ring import FrameRing
from wiithrow.vision.tracked_frame import TrackedFrame
from wiithrow.vision.wiimote.frames import IRFrame
from wiithrow.vision.wiimote.protocol import Button

DOTS, MARKERS, POSE, CALIBRATION, REPORT, END = 1, 2, 3, 4, 5, 6
PROCESSED, FLUSHED, REPORTS, CALIBRATED = 1, 2, 3, 4
ARM = 16  # kinds 7-15 left free for other records
MAX_MARKERS = 16
MAX_REPORT_BYTES = 64
MAX_CAMERAS = 6
MAX_JOINTS = 16
SLOT_BYTES = 640

_KIND = struct.Struct("<QB")
_DOTS = struct.Struct("<QBBqddq8d")
_POSE = struct.Struct("<QBq16d")
_REPORT = struct.Struct(f"<QBBdB{MAX_REPORT_BYTES}s")
_END = struct.Struct("<QBBbdq")


@functools.lru_cache(maxsize=MAX_MARKERS + 1)
def _markers_struct(n: int) -> struct.Struct:
    return struct.Struct(f"<QBqdqB{n}q{3 * n}d{n}?{n}B")


@functools.lru_cache(maxsize=MAX_CAMERAS + 1)
def _calibration_struct(cameras: int) -> struct.Struct:
    return struct.Struct(f"<QBB{12 * cameras}d")


@functools.lru_cache(maxsize=MAX_JOINTS + 1)
def _arm_struct(n: int) -> struct.Struct:
    return struct.Struct(f"<QBdB{2 * n}d16d")


assert _markers_struct(MAX_MARKERS).size <= SLOT_BYTES and _calibration_struct(MAX_CAMERAS).size <= SLOT_BYTES
assert _arm_struct(MAX_JOINTS).size <= SLOT_BYTES


class TooLarge(ValueError):
    """A frame with more markers or cameras than a record holds."""


# -- packing (the tracking process: one pack_into and a commit each)


def put_dots(ring: FrameRing, camera: int, frame: IRFrame, stamp_ns: int) -> None:
    k, offset = ring.slot()
    _DOTS.pack_into(
        ring.buf, offset, k, DOTS, camera, frame.seq, frame.t, frame.t_device, stamp_ns, *frame.dots.ravel().tolist()
    )
    ring.commit()


def put_markers(ring: FrameRing, seq: int, frame: TrackedFrame, stamp_ns: int) -> None:
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
        stamp_ns,
        n,
        *frame.ids.tolist(),
        *frame.position.ravel().tolist(),
        *frame.visible.tolist(),
        *frame.n_views.tolist(),
    )
    ring.commit()


def put_pose(ring: FrameRing, T: NDArray[np.float64], stamp_ns: int) -> None:
    k, offset = ring.slot()
    _POSE.pack_into(ring.buf, offset, k, POSE, stamp_ns, *np.asarray(T, dtype=float).ravel().tolist())
    ring.commit()


def put_calibration(ring: FrameRing, Ps: NDArray[np.float64]) -> None:
    Ps = np.asarray(Ps, dtype=float)
    if len(Ps) > MAX_CAMERAS:
        raise TooLarge(f"a rig of {len(Ps)} cameras: a record holds {MAX_CAMERAS}")
    k, offset = ring.slot()
    _calibration_struct(len(Ps)).pack_into(ring.buf, offset, k, CALIBRATION, len(Ps), *Ps.ravel().tolist())
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


# -- unpacking (the writer process)


@dataclass(frozen=True)
class Dots:
    camera: int
    frame: IRFrame
    stamp_ns: int


@dataclass(frozen=True)
class Markers:
    seq: int
    frame: TrackedFrame
    stamp_ns: int


@dataclass(frozen=True)
class Pose:
    T: NDArray[np.float64]
    stamp_ns: int


@dataclass(frozen=True)
class Calibration:
    Ps: NDArray[np.float64]


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


Record = Dots | Markers | Pose | Calibration | Report | End | Arm


def unpack(record: bytes) -> Record:
    """One record as what it carries; ValueError for an unknown kind."""
    kind = _KIND.unpack_from(record, 0)[1]
    if kind == DOTS:
        _, _, camera, seq, t, t_device, stamp_ns, *dots = _DOTS.unpack_from(record, 0)
        frame = IRFrame(
            t=t,
            t_device=t_device,
            seq=seq,
            report_id=0,
            dots=np.array(dots, dtype=float).reshape(4, 2),
            sizes=np.full(4, np.nan),
            buttons=Button(0),
        )
        return Dots(camera, frame, stamp_ns)
    if kind == MARKERS:
        n = record[8 + 1 + 8 + 8 + 8]  # after number, kind, seq, t, stamp_ns
        fields = _markers_struct(n).unpack_from(record, 0)
        seq, t, stamp_ns = fields[2], fields[3], fields[4]
        rest = fields[6:]
        ids = np.array(rest[:n], dtype=np.int64)
        position = np.array(rest[n : 4 * n], dtype=float).reshape(n, 3)
        visible = np.array(rest[4 * n : 5 * n], dtype=bool)
        views = np.array(rest[5 * n : 6 * n], dtype=np.int64)
        unknown = np.full((n, 3), np.nan)
        return Markers(seq, TrackedFrame(t, ids, position, unknown, unknown.copy(), visible, views), stamp_ns)
    if kind == POSE:
        _, _, stamp_ns, *T = _POSE.unpack_from(record, 0)
        return Pose(np.array(T, dtype=float).reshape(4, 4), stamp_ns)
    if kind == CALIBRATION:
        cameras = record[9]
        values = _calibration_struct(cameras).unpack_from(record, 0)[3:]
        return Calibration(np.array(values, dtype=float).reshape(cameras, 3, 4))
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
    raise ValueError(f"a record of unknown kind {kind}")
