"""`Ros2Publisher`: a rig's markers, frames, dots and throws as ROS 2 topics over DDS.

What `--publish` puts on Zenoh, as ROS 2 messages (`messages`) on the DDS topics ROS 2 uses
(`rt/<namespace>/<name>`), with the QoS of `domain.Qos`. Under the namespace (default
`/wiithrow`):

| topic | type | what |
|---|---|---|
| `markers` | mocap4r2_msgs/msg/Markers | each tracked frame: `frame_number` the frame's seq (0, 1, ...), a `Marker` per track: `marker_index` its id, `translation` (m) in `frame_id` (link1); predicted markers included |
| `markers/visualization` | visualization_msgs/msg/MarkerArray | the same for RViz: DELETEALL, then per track a 3 cm sphere (`id` = track id; orange when seen, grey while predicted) and its id as text (ns `wiithrow/ids`) |
| `cameras/<name>/dots` | sensor_msgs/msg/PointCloud | one camera frame: the seen dots as points (x = u, y = v in pixels, z = 0), channel `slot` their slot 0-3; `frame_id` camera_<c> |
| `throws` | std_msgs/msg/String | one executed throw: `ThrowRecord.to_dict` as JSON, with its `index` |
| `/tf_static` | tf2_msgs/msg/TFMessage | link1 -> camera_<c> (each camera's pose, z forward), at start and at every calibration |
| `/tf` | tf2_msgs/msg/TFMessage | base -> link1 (joint 1), when the rig belongs to an arm's session, at most every 20 ms (sampled as frames come, tracked or not) |

Every header's `stamp` is the Unix time of the publication (what ROS 2's clock says; tf looks
transforms up by it). Writes are serialised by a lock (the follower's thread, a throw).
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np
from numpy.typing import NDArray
from scipy.spatial.transform import Rotation

from wiithrow.app.ros2 import messages as m
from wiithrow.app.ros2.domain import Qos, Ros2Domain, ros_name, topic_name
from wiithrow.vision.files import dumps_strict
from wiithrow.vision.geometry import decompose
from wiithrow.vision.tracker import TrackedFrame
from wiithrow.vision.wiimote.frames import IRFrame

DEFAULT_NAMESPACE = "/wiithrow"
TF_PERIOD_S = 0.02
LINGER_S = 0.3
SEEN = m.ColorRGBA(r=1.0, g=0.3, b=0.1, a=1.0)
PREDICTED = m.ColorRGBA(r=0.6, g=0.6, b=0.6, a=0.6)
MARKER_SIZE_M = 0.03


def camera_frame(camera: int) -> str:
    return f"camera_{camera}"


def transform(T: NDArray[np.float64], parent: str, child: str, stamp: m.Time) -> m.TransformStamped:
    """A TransformStamped of the 4x4 pose `T` of `child` in `parent`."""
    x, y, z, w = Rotation.from_matrix(T[:3, :3]).as_quat().tolist()
    tx, ty, tz = (float(v) for v in T[:3, 3])
    return m.TransformStamped(
        header=m.Header(stamp=stamp, frame_id=parent),
        child_frame_id=child,
        transform=m.Transform(translation=m.Vector3(tx, ty, tz), rotation=m.Quaternion(x, y, z, w)),
    )


def camera_poses(Ps: NDArray[np.float64]) -> list[NDArray[np.float64]]:
    """Each camera's pose in the calibration's frame (x right, y down, z forward, as ROS' optical frames)."""
    poses = []
    for P in np.asarray(Ps, dtype=float):
        d = decompose(P)
        T = np.eye(4)
        T[:3, :3] = d.R.T
        T[:3, 3] = d.center
        poses.append(T)
    return poses


def markers_message(frame: TrackedFrame, seq: int, frame_id: str, stamp: m.Time) -> m.MocapMarkers:
    return m.MocapMarkers(
        header=m.Header(stamp=stamp, frame_id=frame_id),
        frame_number=seq,
        markers=[
            m.MocapMarker(id_type=m.USE_INDEX, marker_index=int(i), marker_name="", translation=m.Point(*map(float, p)))
            for i, p in zip(frame.ids.tolist(), frame.position)
        ],
    )


def marker_array(frame: TrackedFrame, frame_id: str, stamp: m.Time) -> m.MarkerArray:
    """RViz's view of one tracked frame: DELETEALL (tracks that ended vanish), then a sphere and a label per track."""
    header = m.Header(stamp=stamp, frame_id=frame_id)
    out = [m.Marker(header=header, ns="wiithrow/markers", action=m.DELETEALL)]
    for i, p, seen in zip(frame.ids.tolist(), frame.position, frame.visible.tolist()):
        x, y, z = (float(v) for v in p)
        color = SEEN if seen else PREDICTED
        out.append(
            m.Marker(
                header=header,
                ns="wiithrow/markers",
                id=int(i),
                type=m.SPHERE,
                action=m.ADD,
                pose=m.Pose(position=m.Point(x, y, z)),
                scale=m.Vector3(MARKER_SIZE_M, MARKER_SIZE_M, MARKER_SIZE_M),
                color=color,
            )
        )
        out.append(
            m.Marker(
                header=header,
                ns="wiithrow/ids",
                id=int(i),
                type=m.TEXT_VIEW_FACING,
                action=m.ADD,
                pose=m.Pose(position=m.Point(x, y, z + 0.04)),
                scale=m.Vector3(0.0, 0.0, 0.03),
                color=color,
                text=str(i),
            )
        )
    return m.MarkerArray(markers=out)


def dots_message(camera: int, frame: IRFrame, stamp: m.Time) -> m.PointCloud:
    points, slots = [], []
    for slot, (u, v) in enumerate(np.asarray(frame.dots, dtype=float)):
        if np.isfinite(u) and np.isfinite(v):
            points.append(m.Point32(float(u), float(v), 0.0))
            slots.append(float(slot))
    return m.PointCloud(
        header=m.Header(stamp=stamp, frame_id=camera_frame(camera)),
        points=points,
        channels=[m.ChannelFloat32(name="slot", values=slots)],
    )


def now_stamp() -> m.Time:
    return m.stamp(time.time_ns())


class Ros2Publisher:
    """The topics of the module docstring on `domain` (open); `arm_pose`, when given, says where
    link1 is in base now (4x4) or None: `/tf` then carries it."""

    def __init__(
        self,
        domain: Ros2Domain,
        camera_names: Sequence[str],
        frame_name: str,
        *,
        namespace: str = DEFAULT_NAMESPACE,
        arm_pose: Callable[[], NDArray[np.float64] | None] | None = None,
    ) -> None:
        from cyclonedds.pub import DataWriter
        from cyclonedds.topic import Topic

        self.domain = domain
        self.namespace = namespace
        self.frame_name = frame_name
        self.camera_names = list(camera_names)
        self.arm_pose = arm_pose
        participant = domain.participant

        def writer(name: str, kind: type, qos: Any) -> Any:
            return DataWriter(participant, Topic(participant, topic_name(namespace, name), kind, qos=qos), qos=qos)

        self.topics = {
            "markers": topic_name(namespace, "markers"),
            "markers/visualization": topic_name(namespace, "markers/visualization"),
            "throws": topic_name(namespace, "throws"),
            "/tf": topic_name(namespace, "/tf"),
            "/tf_static": topic_name(namespace, "/tf_static"),
        }
        self._markers = writer("markers", m.MocapMarkers, Qos.sensor_data())
        self._visualization = writer("markers/visualization", m.MarkerArray, Qos.sensor_data())
        self._dots = [
            writer(f"cameras/{ros_name(name)}/dots", m.PointCloud, Qos.sensor_data()) for name in self.camera_names
        ]
        self._throws = writer("throws", m.String, Qos.default())
        self._tf = writer("/tf", m.TFMessage, Qos.tf())
        self._tf_static = writer("/tf_static", m.TFMessage, Qos.tf_static())
        self.markers_sent = 0
        self.dots_sent = [0] * len(self.camera_names)
        self.throws_sent = 0
        self.tf_sent = 0
        self._last_tf = -1e9
        self._lock = threading.Lock()

    def dots_topic(self, camera: int) -> str:
        return topic_name(self.namespace, f"cameras/{ros_name(self.camera_names[camera])}/dots")

    def publish_markers(self, frame: TrackedFrame, stamp: m.Time | None = None) -> int:
        """Write one tracked frame (Markers and MarkerArray); its seq (`frame_number`)."""
        stamp = stamp or now_stamp()
        with self._lock:
            seq = self.markers_sent
            self._markers.write(markers_message(frame, seq, self.frame_name, stamp))
            self._visualization.write(marker_array(frame, self.frame_name, stamp))
            self.markers_sent += 1
        self._sample_arm(stamp)
        return seq

    def publish_dots(self, camera: int, frame: IRFrame) -> int:
        """Write one camera frame (and /tf when due: the arm moves whether markers are tracked or not)."""
        stamp = now_stamp()
        with self._lock:
            seq = self.dots_sent[camera]
            self._dots[camera].write(dots_message(camera, frame, stamp))
            self.dots_sent[camera] += 1
        self._sample_arm(stamp)
        return seq

    def publish_calibration(self, Ps: NDArray[np.float64] | None) -> None:
        """`/tf_static`: link1 -> each camera (transient local: a late subscriber gets the last)."""
        if Ps is None:
            return
        stamp = now_stamp()
        message = m.TFMessage(
            transforms=[transform(T, self.frame_name, camera_frame(c), stamp) for c, T in enumerate(camera_poses(Ps))]
        )
        with self._lock:
            self._tf_static.write(message)

    def publish_throw(self, index: int, result: dict[str, Any]) -> int:
        with self._lock:
            seq = self.throws_sent
            self._throws.write(m.String(data=dumps_strict({"index": index, "result": result})))
            self.throws_sent += 1
            return seq

    def publish_transforms(self, transforms: Sequence[m.TransformStamped]) -> None:
        with self._lock:
            self._tf.write(m.TFMessage(transforms=list(transforms)))
            self.tf_sent += 1

    def _sample_arm(self, stamp: m.Time) -> None:
        if self.arm_pose is None or time.monotonic() - self._last_tf < TF_PERIOD_S:
            return
        self._last_tf = time.monotonic()
        try:
            T = self.arm_pose()
        except Exception:  # an arm that cannot say where it is now: no sample this time
            return
        if T is not None:
            self.publish_transforms([transform(np.asarray(T, dtype=float), "base", "link1", stamp)])

    def subscribers(self) -> int:
        """How many readers of `markers` are matched."""
        return len(self._markers.get_matched_subscriptions())

    def wait_for_subscribers(self, timeout_s: float, count: int = 1) -> bool:
        end = time.monotonic() + timeout_s
        while self.subscribers() < count:
            if time.monotonic() >= end:
                return False
            time.sleep(0.01)
        return True

    def drain(self, timeout_s: float = 1.0) -> None:
        """Before the domain closes: wait for the reliable topics' acknowledgements, and `LINGER_S`
        for the best-effort ones (nothing acknowledges them; deleting a writer drops what it has
        not sent yet)."""
        from cyclonedds.util import duration

        for writer in (self._throws, self._tf, self._tf_static):
            try:
                writer.wait_for_acks(duration(seconds=timeout_s))
            except Exception:  # no reader, or the domain is gone: nothing to wait for
                pass
        time.sleep(LINGER_S)

    def announcement(self) -> str:
        return f"ROS 2 topics under {self.namespace or '/'} (and /tf, /tf_static) on DDS domain {self.domain.domain_id}"

    def summary(self) -> str:
        return (
            f"published {self.markers_sent} marker frames, {sum(self.dots_sent)} camera frames, {self.tf_sent} /tf "
            f"and {self.throws_sent} throws as ROS 2 topics under {self.namespace or '/'}"
        )
