"""The CDR bytes of the channels' ROS 2 messages, packed by hand: what the ROS 2 publisher's DDS
writers send and what a ROS 2 bag holds.

cyclonedds-python's serializer walks each `wiithrow.app.ros2.messages` type field by field in Python
(about a millisecond for a frame's MarkerArray); these functions write the same bytes from the
values directly, with `struct`, about 20x cheaper. `tests/app/test_ros2_fast_cdr.py` checks them
equal to cyclonedds's own `serialize(use_version_2=False)` on seeded random messages.

The layout (XCDR1, little endian; what the ROS 2 publisher asks every writer for):
  - a 4-byte encapsulation header `00 01 00 00` (CDR_LE, options 0), then the fields in order;
  - each primitive aligned to its own size (int8/bool 1, int32/uint32/float32 4, float64 8),
    counted from the byte after the header (`_pad`);
  - a string: uint32 byte count including the terminating NUL, the UTF-8 bytes, the NUL;
  - a sequence: uint32 count, then the items (an empty one: no alignment after its count); a
    struct adds no bytes or alignment of its own.
A Marker (a MarkerArray's bulk) is one `struct.pack` whose format has the padding written in
(`_marker_struct`: the alignment depends only on where it starts modulo 8 and its strings'
lengths, so the formats are few and cached).
A writer sends whole 4-byte words (`padded`: cyclonedds's `DataWriter.write` pads the same way).
"""

from __future__ import annotations

import functools
import struct
from collections.abc import Sequence
from typing import Any

import numpy as np
from numpy.typing import NDArray

HEADER = b"\x00\x01\x00\x00"
_ZEROS = b"\x00" * 8
_I32_U32 = struct.Struct("<iI")
_U32 = struct.Struct("<I")
_U32_U32 = struct.Struct("<II")
_I32x3 = struct.Struct("<iii")
_F64x3 = struct.Struct("<3d")
_F64x7 = struct.Struct("<7d")
_ID_TYPE = struct.Struct("<b")
_INDEX_EMPTY_NAME = struct.Struct("<iIx")  # marker_index, marker_name "" (length 1, its NUL)


def _pad(buf: bytearray, size: int) -> None:
    """Zeros up to the next multiple of `size` (1, 4 or 8) of the offset after the header."""
    pad = -(len(buf) - 4) % size
    if pad:
        buf += _ZEROS[:pad]


def _string(buf: bytearray, data: bytes) -> None:
    """An (already UTF-8) string: aligned uint32 length with the NUL, the bytes, the NUL."""
    _pad(buf, 4)
    buf += _U32.pack(len(data) + 1)
    buf += data
    buf += b"\x00"


def _header(buf: bytearray, sec: int, nanosec: int, frame_id: bytes) -> None:
    """std_msgs/Header: stamp (int32 sec, uint32 nanosec), frame_id."""
    _pad(buf, 4)
    buf += _I32_U32.pack(sec, nanosec)
    _string(buf, frame_id)


def padded(data: bytes | bytearray) -> bytes:
    """`data` with zeros to a whole number of 4-byte words, as a DDS writer sends it."""
    return bytes(data) + _ZEROS[: -len(data) % 4]


def mocap_markers(
    sec: int, nanosec: int, frame_id: str, frame_number: int, ids: Sequence[int], positions: NDArray[np.float64]
) -> bytes:
    """mocap4r2_msgs/Markers: a Marker per id (id_type USE_INDEX, marker_index its id, no name,
    translation its position)."""
    buf = bytearray(HEADER)
    _header(buf, sec, nanosec, frame_id.encode())
    _pad(buf, 4)
    buf += _U32_U32.pack(frame_number, len(ids))
    for i, (x, y, z) in zip(ids, np.asarray(positions, dtype=float).reshape(-1, 3).tolist()):
        buf += _ID_TYPE.pack(1)  # USE_INDEX; int8: no alignment
        _pad(buf, 4)
        buf += _INDEX_EMPTY_NAME.pack(int(i), 1)
        _pad(buf, 8)
        buf += _F64x3.pack(x, y, z)
    return bytes(buf)


class _Layout:
    """A struct format for a run of fields starting at a known offset modulo 8, with each
    field's alignment padding written in as pad bytes (`x`): one `struct.pack` for the run."""

    def __init__(self, offset: int) -> None:
        self.offset = offset
        self.format = "<"

    def field(self, code: str, size: int, align: int) -> None:
        pad = -self.offset % align
        self.format += f"{pad}x{code}"
        self.offset += pad + size

    def string(self, length: int) -> None:
        """A string of `length` UTF-8 bytes: its count with the NUL, then `(length + 1)s` (the NUL is struct's padding)."""
        self.field("I", 4, 4)
        self.field(f"{length + 1}s", length + 1, 1)


@functools.lru_cache(maxsize=1024)
def _marker_struct(offset8: int, frame_id: int, ns: int, text: int) -> struct.Struct:
    """The layout of one `_marker` that starts at `offset8` (mod 8), for strings of these byte lengths."""
    layout = _Layout(offset8)
    layout.field("iI", 8, 4)  # header.stamp
    layout.string(frame_id)
    layout.string(ns)
    layout.field("iii", 12, 4)  # id, type, action
    layout.field("10d", 80, 8)  # pose (position, orientation), scale
    layout.field("4f", 16, 4)  # color
    layout.field("iI", 8, 4)  # lifetime
    layout.field("?", 1, 1)  # frame_locked
    layout.field("II", 8, 4)  # points [], colors []
    layout.string(0)  # texture_resource
    layout.field("iI", 8, 4)  # texture.header.stamp
    layout.string(0)  # texture.header.frame_id
    layout.string(0)  # texture.format
    layout.field("II", 8, 4)  # texture.data [], uv_coordinates []
    layout.string(text)
    layout.string(0)  # mesh_resource
    layout.string(0)  # mesh_file.filename
    layout.field("I", 4, 4)  # mesh_file.data []
    layout.field("?", 1, 1)  # mesh_use_embedded_materials
    return struct.Struct(layout.format)


def _marker(
    offset: int,
    header: tuple[int, int, bytes],
    ns: bytes,
    ints: tuple[int, int, int],
    body: tuple[float, ...],
    text: bytes,
) -> bytes:
    """visualization_msgs/Marker starting at `offset`, with empty points, colors, uv_coordinates, a
    default texture and mesh_file: `ints` (id, type, action), `body` pose xyz + xyzw, scale xyz,
    color rgba (lifetime 0, not frame locked)."""
    sec, nanosec, frame_id = header
    layout = _marker_struct(offset % 8, len(frame_id), len(ns), len(text))
    # fmt: off
    return layout.pack(
        sec, nanosec, len(frame_id) + 1, frame_id, len(ns) + 1, ns, *ints, *body, 0, 0, False,
        0, 0, 1, b"", 0, 0, 1, b"", 1, b"", 0, 0, len(text) + 1, text, 1, b"", 1, b"", 0, False,
    )
    # fmt: on


#: (id, type, action, pose, scale, color, text) of one visualization_msgs/Marker that `marker_array` writes.
MarkerSpec = tuple[int, int, int, Sequence[float], Sequence[float], Sequence[float], str]


def marker_array(sec: int, nanosec: int, frame_id: str, markers: Sequence[tuple[str, MarkerSpec]]) -> bytes:
    """visualization_msgs/MarkerArray of `(ns, spec)` markers sharing one header (see `_marker`)."""
    parts = [HEADER, _U32.pack(len(markers))]
    offset = 4
    header = (sec, nanosec, frame_id.encode())
    for ns, (i, kind, action, pose, scale, color, text) in markers:
        data = _marker(offset, header, ns.encode(), (i, kind, action), (*pose, *scale, *color), text.encode())
        parts.append(data)
        offset += len(data)
    return b"".join(parts)


def point_cloud(
    sec: int,
    nanosec: int,
    frame_id: str,
    points: Sequence[Sequence[float]] | NDArray[np.float32],
    channels: Sequence[tuple[str, Sequence[float] | NDArray[np.float32]]],
) -> bytes:
    """sensor_msgs/PointCloud: `points` (N, 3) as float32 xyz, each channel a name and N float32."""
    buf = bytearray(HEADER)
    _header(buf, sec, nanosec, frame_id.encode())
    xyz = [c for point in _listed(points) for c in point]
    _pad(buf, 4)
    buf += _U32.pack(len(xyz) // 3)
    buf += struct.pack(f"<{len(xyz)}f", *xyz)
    buf += _U32.pack(len(channels))
    for name, values in channels:
        _string(buf, name.encode())
        _pad(buf, 4)
        floats = _listed(values)
        buf += _U32.pack(len(floats))
        buf += struct.pack(f"<{len(floats)}f", *floats)
    return bytes(buf)


def _listed(values: Any) -> list[Any]:
    """An array's values as Python lists (what struct packs), a sequence as a list."""
    return values.tolist() if isinstance(values, np.ndarray) else list(values)


#: (sec, nanosec, parent, child, translation xyz, rotation xyzw) of one geometry_msgs/TransformStamped.
TransformSpec = tuple[int, int, str, str, Sequence[float], Sequence[float]]


def tf_message(transforms: Sequence[TransformSpec]) -> bytes:
    """tf2_msgs/TFMessage."""
    buf = bytearray(HEADER)
    buf += _U32.pack(len(transforms))
    for sec, nanosec, parent, child, translation, rotation in transforms:
        _header(buf, sec, nanosec, parent.encode())
        _string(buf, child.encode())
        _pad(buf, 8)
        buf += _F64x7.pack(*translation, *rotation)
    return bytes(buf)


def string(data: str) -> bytes:
    """std_msgs/String."""
    buf = bytearray(HEADER)
    _string(buf, data.encode())
    return bytes(buf)


def _strings(buf: bytearray, values: Sequence[str]) -> None:
    """A string[]: its count, then each string."""
    _pad(buf, 4)
    buf += _U32.pack(len(values))
    for value in values:
        _string(buf, value.encode())


def _float64s(buf: bytearray, values: Sequence[float]) -> None:
    """A float64[]: its count, then the values aligned to 8 (none: no alignment)."""
    _pad(buf, 4)
    buf += _U32.pack(len(values))
    if values:
        _pad(buf, 8)
        buf += struct.pack(f"<{len(values)}d", *values)


def joint_state(
    sec: int,
    nanosec: int,
    frame_id: str,
    names: Sequence[str],
    position: Sequence[float],
    velocity: Sequence[float],
    effort: Sequence[float] = (),
) -> bytes:
    """sensor_msgs/JointState."""
    buf = bytearray(HEADER)
    _header(buf, sec, nanosec, frame_id.encode())
    _strings(buf, names)
    for values in (position, velocity, effort):
        _float64s(buf, values)
    return bytes(buf)


#: (positions, velocities, time_from_start sec, nanosec) of one trajectory_msgs/JointTrajectoryPoint.
PointSpec = tuple[Sequence[float], Sequence[float], int, int]


def joint_trajectory(sec: int, nanosec: int, frame_id: str, names: Sequence[str], points: Sequence[PointSpec]) -> bytes:
    """trajectory_msgs/JointTrajectory (each point's accelerations and effort empty)."""
    buf = bytearray(HEADER)
    _header(buf, sec, nanosec, frame_id.encode())
    _strings(buf, names)
    _pad(buf, 4)
    buf += _U32.pack(len(points))
    for positions, velocities, at_sec, at_nanosec in points:
        for values in (positions, velocities, (), ()):
            _float64s(buf, values)
        _pad(buf, 4)
        buf += _I32_U32.pack(at_sec, at_nanosec)
    return bytes(buf)
