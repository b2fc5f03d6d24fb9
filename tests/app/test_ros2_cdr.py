"""The CDR bytes of the ROS 2 messages wiithrow writes, against references written by hand from
the CDR rules (XCDR1, little endian), and the Python types against the shipped IDL.

CDR as ROS 2 uses it: a 4-byte encapsulation header 00 01 00 00 (CDR, little endian), then the
fields in order, each primitive aligned to its own size (8 for double) counted from the byte after
the header; a string is a uint32 length that counts the terminating NUL, the bytes, the NUL; a
sequence is a uint32 count, then the items; a bool is one byte; a struct adds nothing of its own.
Below, every padding is written out (`pad(n)`) where the rules put it, with the offset it reaches.
"""

from __future__ import annotations

import dataclasses
import struct

import pytest

from tests.helpers.ros2_idl import load_types
from wiithrow.app.ros2 import messages as m

HEADER = b"\x00\x01\x00\x00"  # encapsulation: CDR_LE (XCDR1, little endian), options 0


def u32(v: int) -> bytes:
    return struct.pack("<I", v)


def i32(v: int) -> bytes:
    return struct.pack("<i", v)


def f32(*v: float) -> bytes:
    return struct.pack(f"<{len(v)}f", *v)


def f64(*v: float) -> bytes:
    return struct.pack(f"<{len(v)}d", *v)


def string(s: str) -> bytes:
    return u32(len(s) + 1) + s.encode() + b"\x00"


def pad(n: int) -> bytes:
    return b"\x00" * n


def cdr(message) -> bytes:
    return message.serialize(use_version_2=False, endianness=None)


def test_mocap4r2_markers_bytes():
    message = m.MocapMarkers(
        header=m.Header(stamp=m.Time(sec=1, nanosec=2), frame_id="l"),
        frame_number=3,
        markers=[
            m.MocapMarker(id_type=m.USE_INDEX, marker_index=4, marker_name="", translation=m.Point(1.0, 2.0, 3.0))
        ],
    )
    reference = b"".join(
        [
            i32(1),  # 0: header.stamp.sec
            u32(2),  # 4: header.stamp.nanosec
            string("l"),  # 8: frame_id: length 2, 'l', NUL -> 14
            pad(2),  # 14 -> 16: uint32
            u32(3),  # 16: frame_number
            u32(1),  # 20: markers: one
            b"\x01",  # 24: id_type (int8) USE_INDEX
            pad(3),  # 25 -> 28: int32
            i32(4),  # 28: marker_index
            string(""),  # 32: marker_name: length 1, NUL -> 37
            pad(3),  # 37 -> 40: double
            f64(1.0, 2.0, 3.0),  # 40: translation -> 64
        ]
    )
    assert cdr(message) == HEADER + reference


def test_tf_message_bytes():
    message = m.TFMessage(
        transforms=[
            m.TransformStamped(
                header=m.Header(stamp=m.Time(sec=1, nanosec=2), frame_id="base"),
                child_frame_id="link1",
                transform=m.Transform(translation=m.Vector3(0.1, 0.2, 0.3), rotation=m.Quaternion(0.0, 0.0, 0.6, 0.8)),
            )
        ]
    )
    reference = b"".join(
        [
            u32(1),  # 0: transforms: one
            i32(1),  # 4: stamp.sec
            u32(2),  # 8: stamp.nanosec
            string("base"),  # 12: length 5, 'base', NUL -> 21
            pad(3),  # 21 -> 24
            string("link1"),  # 24: child_frame_id -> 34
            pad(6),  # 34 -> 40: double
            f64(0.1, 0.2, 0.3),  # 40: translation -> 64
            f64(0.0, 0.0, 0.6, 0.8),  # 64: rotation x y z w -> 96
        ]
    )
    assert cdr(message) == HEADER + reference


def test_point_cloud_bytes():
    message = m.PointCloud(
        header=m.Header(stamp=m.Time(sec=3, nanosec=4), frame_id="camera_0"),
        points=[m.Point32(512.0, 384.0, 0.0)],
        channels=[m.ChannelFloat32(name="slot", values=[2.0])],
    )
    reference = b"".join(
        [
            i32(3),  # 0: stamp.sec
            u32(4),  # 4: stamp.nanosec
            string("camera_0"),  # 8: length 9 -> 21
            pad(3),  # 21 -> 24
            u32(1),  # 24: points: one
            f32(512.0, 384.0, 0.0),  # 28: x y z (float32) -> 40
            u32(1),  # 40: channels: one
            string("slot"),  # 44: name -> 53
            pad(3),  # 53 -> 56
            u32(1),  # 56: values: one
            f32(2.0),  # 60 -> 64
        ]
    )
    assert cdr(message) == HEADER + reference


def test_string_bytes():
    assert cdr(m.String(data="{}")) == HEADER + u32(3) + b"{}\x00"  # length counts the NUL


def test_marker_array_bytes():
    marker = m.Marker(
        header=m.Header(stamp=m.Time(sec=5, nanosec=6), frame_id="l1"),
        ns="n",
        id=7,
        type=m.SPHERE,
        action=m.ADD,
        pose=m.Pose(position=m.Point(1.0, 2.0, 3.0), orientation=m.Quaternion(0.0, 0.0, 0.0, 1.0)),
        scale=m.Vector3(0.5, 0.5, 0.5),
        color=m.ColorRGBA(1.0, 0.5, 0.25, 1.0),
        lifetime=m.Duration(sec=0, nanosec=0),
        frame_locked=True,
        points=[m.Point(4.0, 5.0, 6.0)],
        colors=[],
        texture_resource="",
        texture=m.CompressedImage(header=m.Header(), format="", data=[9]),
        uv_coordinates=[m.UVCoordinate(0.5, 0.25)],
        text="7",
        mesh_resource="",
        mesh_file=m.MeshFile(filename="", data=[]),
        mesh_use_embedded_materials=False,
    )
    reference = b"".join(
        [
            u32(1),  # 0: markers: one
            i32(5),  # 4: header.stamp.sec
            u32(6),  # 8: nanosec
            string("l1"),  # 12: frame_id -> 19
            pad(1),  # 19 -> 20
            string("n"),  # 20: ns -> 26
            pad(2),  # 26 -> 28
            i32(7),  # 28: id
            i32(2),  # 32: type SPHERE
            i32(0),  # 36: action ADD
            f64(1.0, 2.0, 3.0),  # 40: pose.position (40 is 8-aligned) -> 64
            f64(0.0, 0.0, 0.0, 1.0),  # 64: pose.orientation -> 96
            f64(0.5, 0.5, 0.5),  # 96: scale -> 120
            f32(1.0, 0.5, 0.25, 1.0),  # 120: color r g b a -> 136
            i32(0),  # 136: lifetime.sec
            u32(0),  # 140: lifetime.nanosec
            b"\x01",  # 144: frame_locked
            pad(3),  # 145 -> 148
            u32(1),  # 148: points: one
            f64(4.0, 5.0, 6.0),  # 152 (8-aligned): the point -> 176
            u32(0),  # 176: colors: none
            string(""),  # 180: texture_resource -> 185
            pad(3),  # 185 -> 188
            i32(0),  # 188: texture.header.stamp.sec
            u32(0),  # 192: nanosec
            string(""),  # 196: texture.header.frame_id -> 201
            pad(3),  # 201 -> 204
            string(""),  # 204: texture.format -> 209
            pad(3),  # 209 -> 212
            u32(1),  # 212: texture.data: one byte
            b"\x09",  # 216
            pad(3),  # 217 -> 220
            u32(1),  # 220: uv_coordinates: one
            f32(0.5, 0.25),  # 224: u v -> 232
            string("7"),  # 232: text -> 238
            pad(2),  # 238 -> 240
            string(""),  # 240: mesh_resource -> 245
            pad(3),  # 245 -> 248
            string(""),  # 248: mesh_file.filename -> 253
            pad(3),  # 253 -> 256
            u32(0),  # 256: mesh_file.data: none
            b"\x00",  # 260: mesh_use_embedded_materials
        ]
    )
    assert len(reference) == 261
    assert cdr(m.MarkerArray(markers=[marker])) == HEADER + reference


LEAVES = [
    (m.Time(sec=-1, nanosec=5), i32(-1) + u32(5)),
    (m.Duration(sec=2, nanosec=3), i32(2) + u32(3)),
    (m.Header(stamp=m.Time(1, 2), frame_id="ab"), i32(1) + u32(2) + string("ab")),
    (m.ColorRGBA(0.0, 0.5, 1.0, 0.25), f32(0.0, 0.5, 1.0, 0.25)),
    (m.Point(1.5, -2.0, 3.0), f64(1.5, -2.0, 3.0)),
    (m.Point32(1.5, -2.0, 3.0), f32(1.5, -2.0, 3.0)),
    (m.Vector3(1.0, 2.0, 3.0), f64(1.0, 2.0, 3.0)),
    (m.Quaternion(0.0, 0.0, 0.0, 1.0), f64(0.0, 0.0, 0.0, 1.0)),
    (m.Pose(m.Point(1, 2, 3), m.Quaternion(0, 0, 0, 1)), f64(1, 2, 3, 0, 0, 0, 1)),
    (m.Transform(m.Vector3(1, 2, 3), m.Quaternion(0, 0, 0, 1)), f64(1, 2, 3, 0, 0, 0, 1)),
    (m.UVCoordinate(0.5, 0.25), f32(0.5, 0.25)),
    (m.MeshFile("a", [1, 2]), string("a") + pad(2) + u32(2) + b"\x01\x02"),  # 6 -> 8: uint32
    (m.ChannelFloat32("s", [1.0]), string("s") + pad(2) + u32(1) + f32(1.0)),
    (
        m.CompressedImage(m.Header(m.Time(0, 0), ""), "png", [7]),
        i32(0) + u32(0) + string("") + pad(3) + string("png") + u32(1) + b"\x07",  # 13 -> 16, 16 + 8 = 24
    ),
    (
        m.MocapMarker(m.USE_NAME, 1, "a", m.Point(1, 2, 3)),
        b"\x00" + pad(3) + i32(1) + string("a") + pad(2) + f64(1, 2, 3),
    ),
    (
        m.TransformStamped(m.Header(m.Time(0, 0), "a"), "b", m.Transform()),
        i32(0) + u32(0) + string("a") + pad(2) + string("b") + pad(2) + f64(0, 0, 0, 0, 0, 0, 1),  # 14 -> 16, 22 -> 24
    ),
]


@pytest.mark.parametrize(("message", "reference"), LEAVES, ids=lambda x: type(x).__name__)
def test_each_leaf_type_bytes(message, reference):
    assert cdr(message) == HEADER + reference


def test_the_python_types_are_the_shipped_idl_field_for_field():
    idl = load_types()
    classes = [
        value
        for value in vars(m).values()
        if isinstance(value, type) and dataclasses.is_dataclass(value) and hasattr(value, "__idl_typename__")
    ]
    assert len(classes) == 25
    for cls in classes:
        name = cls.__idl_typename__.replace(".", "::")
        assert name.split("::")[2] == "dds_" and name.endswith("_")  # ROS 2's DDS type names
        assert name in idl, name
        assert [f.name for f in dataclasses.fields(cls)] == [f.name for f in dataclasses.fields(idl[name])]
        sample = cls()
        assert idl[name].deserialize(cdr(sample)) is not None  # the IDL's type reads our bytes
        assert cdr(idl[name].deserialize(cdr(sample))) == cdr(sample)
