"""The hand-packed CDR (`wiithrow.app.ros2.cdr`) against cyclonedds's own serializer: byte for byte
equal on seeded random messages of each type the publisher writes (empty arrays, 1-4 markers,
strings of odd lengths that move the alignment), and the publisher's frame encoders against the
message objects they replace."""

from __future__ import annotations

import numpy as np
import pytest

from wiithrow.app.ros2 import cdr
from wiithrow.app.ros2 import messages as m
from wiithrow.app.ros2 import publisher as p
from wiithrow.vision.tracked_frame import TrackedFrame
from wiithrow.vision.wiimote.frames import IRFrame

SEEDS = range(8)


def reference(message) -> bytes:
    return message.serialize(use_version_2=False, endianness=None)


def _name(rng: np.random.Generator) -> str:
    return "".join(rng.choice(list("abcxyz_/é"), size=int(rng.integers(0, 12))))


def _frame(rng: np.random.Generator, n: int) -> TrackedFrame:
    ids = np.sort(rng.choice(50, size=n, replace=False)).astype(np.int64)
    return TrackedFrame(
        t=float(rng.uniform(0, 100)),
        ids=ids,
        position=rng.normal(size=(n, 3)),
        velocity=rng.normal(size=(n, 3)),
        filtered=rng.normal(size=(n, 3)),
        visible=rng.random(n) < 0.7,
        n_views=rng.integers(0, 4, size=n),
    )


def _stamp(rng: np.random.Generator) -> m.Time:
    return m.Time(sec=int(rng.integers(-(2**31), 2**31)), nanosec=int(rng.integers(0, 10**9)))


@pytest.mark.parametrize("seed", SEEDS)
@pytest.mark.parametrize("n", [0, 1, 2, 3, 4])
def test_tracked_frames_encode_as_cyclonedds_serializes_them(seed, n):
    rng = np.random.default_rng(seed * 10 + n)
    frame, stamp, frame_id = _frame(rng, n), _stamp(rng), _name(rng)
    seq = int(rng.integers(0, 2**32))
    assert p.markers_bytes(frame, seq, frame_id, stamp) == reference(p.markers_message(frame, seq, frame_id, stamp))
    assert p.marker_array_bytes(frame, frame_id, stamp) == reference(p.marker_array(frame, frame_id, stamp))


@pytest.mark.parametrize("seed", SEEDS)
def test_camera_frames_encode_as_cyclonedds_serializes_them(seed):
    rng = np.random.default_rng(100 + seed)
    dots = rng.uniform(0, 1023, size=(4, 2))
    dots[rng.random(4) < 0.4] = np.nan  # empty slots (all four empty for some seeds)
    frame = IRFrame(t=1.0, t_device=1.0, seq=seed, report_id=0x33, dots=dots, sizes=np.ones(4), buttons=0)
    camera, stamp = int(rng.integers(0, 4)), _stamp(rng)
    assert p.dots_bytes(camera, frame, stamp) == reference(p.dots_message(camera, frame, stamp))


@pytest.mark.parametrize("seed", SEEDS)
def test_point_clouds_with_any_channels_encode_as_cyclonedds_serializes_them(seed):
    rng = np.random.default_rng(200 + seed)
    n = int(rng.integers(0, 5))
    points = rng.normal(size=(n, 3)).astype(np.float32)
    channels = [(_name(rng), rng.normal(size=n).astype(np.float32).tolist()) for _ in range(int(rng.integers(0, 3)))]
    stamp, frame_id = _stamp(rng), _name(rng)
    message = m.PointCloud(
        header=m.Header(stamp=stamp, frame_id=frame_id),
        points=[m.Point32(*map(float, q)) for q in points],
        channels=[m.ChannelFloat32(name=name, values=values) for name, values in channels],
    )
    assert cdr.point_cloud(stamp.sec, stamp.nanosec, frame_id, points, channels) == reference(message)


@pytest.mark.parametrize("seed", SEEDS)
def test_transforms_encode_as_cyclonedds_serializes_them(seed):
    rng = np.random.default_rng(300 + seed)
    transforms = []
    for _ in range(int(rng.integers(0, 4))):
        T = np.eye(4)
        T[:3, :3] = np.linalg.qr(rng.normal(size=(3, 3)))[0] * np.array([1, 1, 1])
        if np.linalg.det(T[:3, :3]) < 0:
            T[:3, 0] *= -1
        T[:3, 3] = rng.normal(size=3)
        transforms.append(p.transform(T, _name(rng), _name(rng), _stamp(rng)))
    assert p.tf_bytes(transforms) == reference(m.TFMessage(transforms=transforms))


@pytest.mark.parametrize("data", ["", "{}", "é" * 3, '{"index": 1, "result": {"hit": true}}'])
def test_strings_encode_as_cyclonedds_serializes_them(data):
    assert cdr.string(data) == reference(m.String(data=data))


def test_padded_makes_whole_words():
    assert [len(cdr.padded(b"x" * n)) for n in range(9)] == [0, 4, 4, 4, 4, 8, 8, 8, 8]
