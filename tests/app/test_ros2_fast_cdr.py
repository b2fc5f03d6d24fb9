"""The hand-packed CDR (`wiithrow.app.channels.cdr`, through `ros2_messages`) against cyclonedds's own
serializer: byte for byte equal on seeded random messages of each type the ROS 2 sink writes (empty
arrays, 1-4 markers, strings of odd lengths that move the alignment), each encoded from the
channel's JSON message as the live publisher and a ROS 2 bag encode it."""

from __future__ import annotations

import json

import numpy as np
import pytest

from wiithrow.app.channels import cdr, ros2_messages
from wiithrow.app.channels import json_messages as jm
from wiithrow.app.channels.json_messages import PREDICTED, SEEN
from wiithrow.app.ros2 import messages as m
from wiithrow.vision.files import dumps_strict
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


def _stamp_ns(rng: np.random.Generator) -> int:
    return int(rng.integers(0, 2**31)) * 1_000_000_000 + int(rng.integers(0, 10**9))


def _time(stamp_ns: int) -> m.Time:
    return m.stamp(stamp_ns)


def _color(c: dict[str, float]) -> m.ColorRGBA:
    return m.ColorRGBA(r=c["r"], g=c["g"], b=c["b"], a=c["a"])


@pytest.mark.parametrize("seed", SEEDS)
@pytest.mark.parametrize("n", [0, 1, 2, 3, 4])
def test_tracked_frames_encode_as_cyclonedds_serializes_them(seed, n):
    rng = np.random.default_rng(seed * 10 + n)
    frame, stamp_ns, frame_id = _frame(rng, n), _stamp_ns(rng), _name(rng)
    seq = int(rng.integers(0, 2**32))
    message = jm.markers_message(frame, frame_id)
    header = m.Header(stamp=_time(stamp_ns), frame_id=frame_id)
    markers = m.MocapMarkers(
        header=header,
        frame_number=seq,
        markers=[
            m.MocapMarker(id_type=m.USE_INDEX, marker_index=int(i), marker_name="", translation=m.Point(*map(float, p)))
            for i, p in zip(frame.ids.tolist(), frame.position)
        ],
    )
    assert ros2_messages.mocap_markers(message, stamp_ns, seq) == reference(markers)
    array = [m.Marker(header=header, ns="wiithrow/markers", action=m.DELETEALL)]
    for i, (x, y, z), seen in zip(frame.ids.tolist(), frame.position.tolist(), frame.visible.tolist()):
        color = _color(SEEN if seen else PREDICTED)
        array.append(
            m.Marker(
                header=header,
                ns="wiithrow/markers",
                id=i,
                type=m.SPHERE,
                action=m.ADD,
                pose=m.Pose(position=m.Point(x, y, z)),
                scale=m.Vector3(0.03, 0.03, 0.03),
                color=color,
            )
        )
        array.append(
            m.Marker(
                header=header,
                ns="wiithrow/ids",
                id=i,
                type=m.TEXT_VIEW_FACING,
                action=m.ADD,
                pose=m.Pose(position=m.Point(x, y, z + 0.04)),
                scale=m.Vector3(0.0, 0.0, 0.03),
                color=color,
                text=str(i),
            )
        )
    assert ros2_messages.marker_array(message, stamp_ns) == reference(m.MarkerArray(markers=array))


@pytest.mark.parametrize("seed", SEEDS)
def test_camera_frames_encode_as_cyclonedds_serializes_them(seed):
    rng = np.random.default_rng(100 + seed)
    dots = rng.uniform(0, 1023, size=(4, 2))
    dots[rng.random(4) < 0.4] = np.nan  # empty slots (all four empty for some seeds)
    frame = IRFrame(t=1.0, t_device=1.0, seq=seed, report_id=0x33, dots=dots, sizes=np.ones(4), buttons=0)
    camera, stamp_ns = int(rng.integers(0, 4)), _stamp_ns(rng)
    seen = [(slot, u, v) for slot, (u, v) in enumerate(dots.tolist()) if np.isfinite(u)]
    message = m.PointCloud(
        header=m.Header(stamp=_time(stamp_ns), frame_id=f"camera_{camera}"),
        points=[m.Point32(u, v, 0.0) for _, u, v in seen],
        channels=[m.ChannelFloat32(name="slot", values=[float(slot) for slot, _, _ in seen])],
    )
    assert ros2_messages.point_cloud(jm.dots_message(camera, frame), stamp_ns) == reference(message)


@pytest.mark.parametrize("seed", SEEDS)
def test_point_clouds_with_any_channels_encode_as_cyclonedds_serializes_them(seed):
    rng = np.random.default_rng(200 + seed)
    n = int(rng.integers(0, 5))
    points = rng.normal(size=(n, 3)).astype(np.float32)
    channels = [(_name(rng), rng.normal(size=n).astype(np.float32).tolist()) for _ in range(int(rng.integers(0, 3)))]
    stamp, frame_id = _time(_stamp_ns(rng)), _name(rng)
    message = m.PointCloud(
        header=m.Header(stamp=stamp, frame_id=frame_id),
        points=[m.Point32(*map(float, q)) for q in points],
        channels=[m.ChannelFloat32(name=name, values=values) for name, values in channels],
    )
    assert cdr.point_cloud(stamp.sec, stamp.nanosec, frame_id, points, channels) == reference(message)


@pytest.mark.parametrize("seed", SEEDS)
def test_transforms_encode_as_cyclonedds_serializes_them(seed):
    rng = np.random.default_rng(300 + seed)
    transforms, stamped = [], []
    for _ in range(int(rng.integers(0, 4))):
        T = np.eye(4)
        T[:3, :3] = np.linalg.qr(rng.normal(size=(3, 3)))[0]
        if np.linalg.det(T[:3, :3]) < 0:
            T[:3, 0] *= -1
        T[:3, 3] = rng.normal(size=3)
        parent, child, stamp_ns = _name(rng), _name(rng), _stamp_ns(rng)
        t = jm.frame_transform(T, parent, child, stamp_ns)
        transforms.append(t)
        p, q = t["translation"], t["rotation"]
        stamped.append(
            m.TransformStamped(
                header=m.Header(stamp=_time(stamp_ns), frame_id=parent),
                child_frame_id=child,
                transform=m.Transform(m.Vector3(p["x"], p["y"], p["z"]), m.Quaternion(q["x"], q["y"], q["z"], q["w"])),
            )
        )
    encoded = ros2_messages.tf_message(jm.transforms_message(transforms))
    assert encoded == reference(m.TFMessage(transforms=stamped))


@pytest.mark.parametrize("seed", SEEDS)
def test_joint_states_and_trajectories_encode_as_cyclonedds_serializes_them(seed):
    rng = np.random.default_rng(400 + seed)
    n = int(rng.integers(0, 8))
    names = [_name(rng) for _ in range(n)]
    stamp_ns = _stamp_ns(rng)
    q, dq = rng.normal(size=n), rng.normal(size=n)
    state = m.JointState(
        header=m.Header(stamp=_time(stamp_ns)), name=names, position=q.tolist(), velocity=dq.tolist(), effort=[]
    )
    assert ros2_messages.joint_state(jm.joints_message(1.0, names, q, dq), stamp_ns) == reference(state)
    times = np.sort(rng.uniform(0, 2, size=int(rng.integers(0, 6))))
    positions = rng.normal(size=(len(times), n))
    message = jm.trajectory_message(1.0, names, times, positions, "a throw")
    points = [
        m.JointTrajectoryPoint(positions=p.tolist(), time_from_start=m.stamp(round((t - times[0]) * 1e9)))
        for t, p in zip(times, positions)
    ]
    trajectory = m.JointTrajectory(
        header=m.Header(stamp=_time(stamp_ns), frame_id="base"), joint_names=names, points=points
    )
    assert ros2_messages.joint_trajectory(message, stamp_ns) == reference(trajectory)


@pytest.mark.parametrize("data", ["", "{}", "é" * 3, '{"index": 1, "outcome": {"hit": true}}'])
def test_strings_encode_as_cyclonedds_serializes_them(data):
    assert cdr.string(data) == reference(m.String(data=data))
    assert ros2_messages.string({"data": data}) == reference(m.String(data=data))  # a robot description
    record = {"index": 3, "outcome": {"text": data}}
    throw = ros2_messages.string(jm.throw_message(1.0, record))  # a throw: its document as JSON
    assert throw == reference(m.String(data=dumps_strict(record)))
    assert json.loads(m.String.deserialize(throw).data) == record


def test_padded_makes_whole_words():
    assert [len(cdr.padded(b"x" * n)) for n in range(9)] == [0, 4, 4, 4, 4, 8, 8, 8, 8]
