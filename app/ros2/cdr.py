"""The CDR bytes of the ROS 2 messages the publisher writes, packed by hand, for the DDS writer.

cyclonedds-python's serializer walks each `messages` type field by field in Python (about a
millisecond for a frame's MarkerArray); these functions write the same bytes from the tracked data
directly, with `struct`, about 20x cheaper. `tests/app/test_ros2_fast_cdr.py` checks them equal to
cyclonedds's own `serialize(use_version_2=False)` on seeded random messages.

The layout (XCDR1, little endian; what `domain.Qos` asks every writer for):
  - a 4-byte encapsulation header `00 01 00 00` (CDR_LE, options 0), then the fields in order;
  - each primitive aligned to its own size (int8/bool 1, int32/uint32/float32 4, float64 8),
    counted from the byte after the header (`_pad`);
  - a string: uint32 byte count including the terminating NUL, the UTF-8 bytes, the NUL;
  - a sequence: uint32 count, then the items; a struct adds no bytes or alignment of its own.
A writer sends whole 4-byte words (`padded`: cyclonedds's `DataWriter.write` pads the same way).
"""

from __future__ import annotations

import struct
from collections.abc import Sequence

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
_MARKER_BODY = struct.Struct("<10d4fiI?")  # pose (7), scale (3), color (4 f32), lifetime, frame_locked
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


def _marker(
    buf: bytearray,
    header: tuple[int, int, bytes],
    ns: bytes,
    ints: tuple[int, int, int],
    body: tuple[float, ...],
    text: bytes,
) -> None:
    """visualization_msgs/Marker with empty points, colors, uv_coordinates, a default texture and
    mesh_file: `ints` (id, type, action), `body` pose xyz + xyzw, scale xyz, color rgba."""
    _header(buf, *header)
    _string(buf, ns)
    _pad(buf, 4)
    buf += _I32x3.pack(*ints)
    _pad(buf, 8)
    buf += _MARKER_BODY.pack(*body, 0, 0, False)  # lifetime 0, frame_locked false
    _pad(buf, 4)
    # points [], colors [], texture_resource "", texture (stamp 0 0, frame_id "", format "", data [])
    buf += b"\x00\x00\x00\x00\x00\x00\x00\x00\x01\x00\x00\x00\x00"
    _pad(buf, 4)
    buf += b"\x00\x00\x00\x00\x00\x00\x00\x00\x01\x00\x00\x00\x00"
    _pad(buf, 4)
    buf += b"\x01\x00\x00\x00\x00"
    _pad(buf, 4)
    buf += b"\x00\x00\x00\x00\x00\x00\x00\x00"  # texture.data [], uv_coordinates []
    _string(buf, text)
    _pad(buf, 4)
    buf += b"\x01\x00\x00\x00\x00"  # mesh_resource ""
    _pad(buf, 4)
    buf += b"\x01\x00\x00\x00\x00"  # mesh_file.filename ""
    _pad(buf, 4)
    buf += b"\x00\x00\x00\x00\x00"  # mesh_file.data [], mesh_use_embedded_materials false


#: (id, type, action, pose, scale, color, text) of one visualization_msgs/Marker that `marker_array` writes.
MarkerSpec = tuple[int, int, int, Sequence[float], Sequence[float], Sequence[float], str]


def marker_array(sec: int, nanosec: int, frame_id: str, markers: Sequence[tuple[str, MarkerSpec]]) -> bytes:
    """visualization_msgs/MarkerArray of `(ns, spec)` markers sharing one header (see `_marker`)."""
    buf = bytearray(HEADER)
    buf += _U32.pack(len(markers))
    header = (sec, nanosec, frame_id.encode())
    for ns, (i, kind, action, pose, scale, color, text) in markers:
        _marker(buf, header, ns.encode(), (i, kind, action), (*pose, *scale, *color), text.encode())
    return bytes(buf)


def point_cloud(
    sec: int,
    nanosec: int,
    frame_id: str,
    points: NDArray[np.float32],
    channels: Sequence[tuple[str, Sequence[float] | NDArray[np.float32]]],
) -> bytes:
    """sensor_msgs/PointCloud: `points` (N, 3) as float32 xyz, each channel a name and N float32."""
    buf = bytearray(HEADER)
    _header(buf, sec, nanosec, frame_id.encode())
    xyz = np.ascontiguousarray(points, dtype="<f4").reshape(-1, 3)
    _pad(buf, 4)
    buf += _U32.pack(len(xyz))
    buf += xyz.tobytes()
    buf += _U32.pack(len(channels))
    for name, values in channels:
        _string(buf, name.encode())
        _pad(buf, 4)
        array = np.ascontiguousarray(values, dtype="<f4").reshape(-1)
        buf += _U32.pack(len(array))
        buf += array.tobytes()
    return bytes(buf)


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
