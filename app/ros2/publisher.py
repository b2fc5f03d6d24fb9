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
transforms up by it), taken when the frame is handed over (before the writer thread's queue).
The samples are CDR packed by `cdr` and handed to the DDS writer as bytes (`_write_cdr`);
writes are serialised by a lock (the writer thread, a throw, a calibration).
"""

from __future__ import annotations

import math
import queue
import threading
import time
from collections.abc import Callable, Sequence
from typing import Any, cast

import numpy as np
from numpy.typing import NDArray

from wiithrow.app.ros2 import cdr
from wiithrow.app.ros2 import messages as m
from wiithrow.app.ros2.domain import Qos, Ros2Domain, ros_name, topic_name
from wiithrow.vision.files import dumps_strict
from wiithrow.vision.geometry import decompose, quaternion_xyzw
from wiithrow.vision.tracked_frame import TrackedFrame
from wiithrow.vision.wiimote.frames import IRFrame

DEFAULT_NAMESPACE = "/wiithrow"
TF_PERIOD_S = 0.02


class ArmPoseSampler:
    """base -> link1 from `arm_pose`, asked at most every `TF_PERIOD_S` (monotonic clock): `due()`
    is the pose when a sample is due, else None (no arm, too soon, or an arm that cannot say where it
    is now: no sample this time). Shared by the in-process and the writer-process publishers."""

    def __init__(self, arm_pose: Callable[[], NDArray[np.float64] | None] | None) -> None:
        self.arm_pose = arm_pose
        self._last = -1e9

    def due(self) -> NDArray[np.float64] | None:
        if self.arm_pose is None or time.monotonic() - self._last < TF_PERIOD_S:
            return None
        self._last = time.monotonic()
        try:
            T = self.arm_pose()
        except Exception:  # an arm that cannot say where it is now: no sample this time
            return None
        return None if T is None else np.asarray(T, dtype=float)


LINGER_S = 0.3
#: Frames the writer thread may be behind (markers and dots together: ~2 s of a 4-camera rig at 100 Hz,
#: ~2 s of a simulated session that runs faster than real time while it catches up).
QUEUE_FRAMES = 1000
SEEN = m.ColorRGBA(r=1.0, g=0.3, b=0.1, a=1.0)
PREDICTED = m.ColorRGBA(r=0.6, g=0.6, b=0.6, a=0.6)
MARKER_SIZE_M = 0.03


def _write_cdr(writer: Any, data: bytes) -> None:
    """Write one sample already in CDR (`cdr`) with `writer`: what `DataWriter.write` does after
    its own serialisation (cyclonedds 11: pad to whole words, `ddspy_write`), so the bytes on the
    wire are the ones cyclonedds would send."""
    from cyclonedds._clayer import ddspy_write  # type: ignore[import-not-found]  # the C layer: no stubs
    from cyclonedds.core import DDSException

    ret = ddspy_write(writer._ref, cdr.padded(data))
    if ret < 0:
        raise DDSException(ret, f"Occurred while writing sample in {writer!r}")


def _has_reader(writer: Any) -> bool:
    """Whether `writer` has a matched reader now (under a microsecond: a C call)."""
    return bool(writer.get_matched_subscriptions())


def camera_frame(camera: int) -> str:
    return f"camera_{camera}"


def transform(T: NDArray[np.float64], parent: str, child: str, stamp: m.Time) -> m.TransformStamped:
    """A TransformStamped of the 4x4 pose `T` of `child` in `parent`."""
    x, y, z, w = quaternion_xyzw(T[:3, :3])
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


# -- the same messages as CDR bytes (`cdr`), what the writers send: no message objects on the way


def markers_bytes(frame: TrackedFrame, seq: int, frame_id: str, stamp: m.Time) -> bytes:
    """`markers_message` as CDR."""
    return cdr.mocap_markers(stamp.sec, stamp.nanosec, frame_id, seq, frame.ids.tolist(), frame.position)


def _rgba(color: m.ColorRGBA) -> tuple[float, float, float, float]:
    return (color.r, color.g, color.b, color.a)


_SEEN, _PREDICTED = _rgba(SEEN), _rgba(PREDICTED)
_SPHERE_SCALE = (MARKER_SIZE_M, MARKER_SIZE_M, MARKER_SIZE_M)
_TEXT_SCALE = (0.0, 0.0, 0.03)
_ZERO_POSE = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0)
_DELETE_ALL: cdr.MarkerSpec = (0, 0, m.DELETEALL, _ZERO_POSE, (0.0, 0.0, 0.0), (0.0, 0.0, 0.0, 0.0), "")


def marker_array_bytes(frame: TrackedFrame, frame_id: str, stamp: m.Time) -> bytes:
    """`marker_array` as CDR."""
    markers: list[tuple[str, cdr.MarkerSpec]] = [("wiithrow/markers", _DELETE_ALL)]
    for i, (x, y, z), seen in zip(frame.ids.tolist(), frame.position.tolist(), frame.visible.tolist()):
        color = _SEEN if seen else _PREDICTED
        markers.append(
            ("wiithrow/markers", (i, m.SPHERE, m.ADD, (x, y, z, 0.0, 0.0, 0.0, 1.0), _SPHERE_SCALE, color, ""))
        )
        markers.append(
            (
                "wiithrow/ids",
                (i, m.TEXT_VIEW_FACING, m.ADD, (x, y, z + 0.04, 0.0, 0.0, 0.0, 1.0), _TEXT_SCALE, color, str(i)),
            )
        )
    return cdr.marker_array(stamp.sec, stamp.nanosec, frame_id, markers)


def dots_bytes(camera: int, frame: IRFrame, stamp: m.Time) -> bytes:
    """`dots_message` as CDR."""
    points, slots = [], []
    for slot, (u, v) in enumerate(np.asarray(frame.dots, dtype=float).tolist()):
        if math.isfinite(u) and math.isfinite(v):
            points.append((u, v, 0.0))
            slots.append(float(slot))
    return cdr.point_cloud(stamp.sec, stamp.nanosec, camera_frame(camera), points, [("slot", slots)])


def tf_bytes(transforms: Sequence[m.TransformStamped]) -> bytes:
    """A TFMessage of `transforms` as CDR."""
    return cdr.tf_message(
        [
            (
                t.header.stamp.sec,
                t.header.stamp.nanosec,
                t.header.frame_id,
                t.child_frame_id,
                (t.transform.translation.x, t.transform.translation.y, t.transform.translation.z),
                (t.transform.rotation.x, t.transform.rotation.y, t.transform.rotation.z, t.transform.rotation.w),
            )
            for t in transforms
        ]
    )


def now_stamp() -> m.Time:
    return m.stamp(time.time_ns())


class _Write:
    """One frame for the writer thread to encode and write (`kind` "markers" or "dots")."""

    __slots__ = ("frame", "index", "kind", "stamp")

    def __init__(self, kind: str, frame: TrackedFrame | IRFrame, index: int, stamp: m.Time) -> None:
        self.kind, self.frame, self.index, self.stamp = kind, frame, index, stamp


class Ros2Publisher:
    """The topics of the module docstring on `domain` (open); `arm_pose`, when given, says where
    link1 is in base now (4x4) or None: `/tf` then carries it.

    `publish_markers` and `publish_dots` (the rig's rate: the tracking thread calls them) encode
    the frame (`cdr`: ~5 us for the markers, ~7 us a camera's dots) and write it on the caller's
    thread (the default), or, with `thread=True`, only stamp, number and queue it for a writer
    thread that encodes and writes it and samples the arm for `/tf`. The queue holds
    `QUEUE_FRAMES`; a frame that finds it full is dropped and counted (`markers_dropped`,
    `dots_dropped`: its seq is never sent, so a subscriber sees the gap), never waited for. (The
    writer thread is not the default: measured on `bench tracking`, handing every frame to another
    thread of the same interpreter costs the tracking thread more, in GIL hand-overs, than the
    packing it saves: docs/integrations/ros2.md.) A frame's sample is encoded only for a topic with a matched
    reader (`samples_written`; `samples_unread` the others: with RViz closed, no MarkerArray is
    packed). Calibration, /tf and
    throws are written always, at once (reliable topics, rare)."""

    def __init__(
        self,
        domain: Ros2Domain,
        camera_names: Sequence[str],
        frame_name: str,
        *,
        namespace: str = DEFAULT_NAMESPACE,
        arm_pose: Callable[[], NDArray[np.float64] | None] | None = None,
        thread: bool = False,
    ) -> None:
        self.domain = domain
        self.namespace = namespace
        self.frame_name = frame_name
        self.camera_names = list(camera_names)
        self.arm_pose = arm_pose

        def writer(name: str, kind: type, qos: Any) -> Any:
            return domain.writer(topic_name(namespace, name), kind, qos)  # the node's, with its type hash

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
        self.markers_sent = 0  # frames numbered (the next seq), written or dropped
        self.dots_sent = [0] * len(self.camera_names)
        self.markers_dropped = 0
        self.dots_dropped = 0
        self.throws_sent = 0
        self.tf_sent = 0
        self.samples_written = 0  # markers, visualization and dots samples handed to DDS
        self.samples_unread = 0  # samples not encoded: their topic had no reader
        self.failure: str | None = None  # why the writer thread stopped writing, if it did
        self._arm_samples = ArmPoseSampler(arm_pose)
        self._lock = threading.Lock()  # one write at a time
        self._count_lock = threading.Lock()  # the seqs and counts (never held during a write)
        self._queue: queue.SimpleQueue[_Write | threading.Event | None] = queue.SimpleQueue()
        self._thread: threading.Thread | None = None
        if thread:
            self._thread = threading.Thread(target=self._run, name="wiithrow-ros2-writer", daemon=True)
            self._thread.start()

    def dots_topic(self, camera: int) -> str:
        return topic_name(self.namespace, f"cameras/{ros_name(self.camera_names[camera])}/dots")

    def publish_markers(self, frame: TrackedFrame, stamp: m.Time | None = None, seq: int | None = None) -> int:
        """Write one tracked frame (Markers and MarkerArray), or queue it; its seq (`frame_number`:
        the next, unless `seq` says it: a writer process numbers as the tracking process did)."""
        stamp = stamp or now_stamp()
        with self._count_lock:
            seq = self.markers_sent if seq is None else seq
            self.markers_sent = seq + 1
            if self._thread is not None and self._queue.qsize() >= QUEUE_FRAMES:
                self.markers_dropped += 1
                return seq
        self._submit(_Write("markers", frame, seq, stamp))
        return seq

    def publish_dots(self, camera: int, frame: IRFrame, stamp: m.Time | None = None) -> int:
        """Write one camera frame (and /tf when due: the arm moves whether markers are tracked or not), or queue it."""
        stamp = stamp or now_stamp()
        with self._count_lock:
            seq = self.dots_sent[camera]
            self.dots_sent[camera] += 1
            if self.arm_pose is None and not _has_reader(self._dots[camera]):  # nothing to write, no /tf to sample
                self.samples_unread += 1
                return seq
            if self._thread is not None and self._queue.qsize() >= QUEUE_FRAMES:
                self.dots_dropped += 1
                return seq
        self._submit(_Write("dots", frame, camera, stamp))
        return seq

    def _submit(self, item: _Write) -> None:
        if self._thread is not None:
            self._queue.put(item)
        else:
            self._write(item)

    def _write(self, item: _Write) -> None:
        """Encode and write one frame (the writer thread, or the caller's with `thread=False`) to
        each of its topics that has a reader (a best-effort, volatile sample with no matched reader
        reaches no one, now or later: it is not encoded)."""
        if item.kind == "markers":
            frame = cast(TrackedFrame, item.frame)
            self._write_if_read(self._markers, lambda: markers_bytes(frame, item.index, self.frame_name, item.stamp))
            self._write_if_read(self._visualization, lambda: marker_array_bytes(frame, self.frame_name, item.stamp))
        else:
            dots = cast(IRFrame, item.frame)
            self._write_if_read(self._dots[item.index], lambda: dots_bytes(item.index, dots, item.stamp))
        self._sample_arm(item.stamp)

    def _write_if_read(self, writer: Any, encode: Callable[[], bytes]) -> None:
        if not _has_reader(writer):
            self.samples_unread += 1
            return
        data = encode()
        with self._lock:
            _write_cdr(writer, data)
            self.samples_written += 1

    def _run(self) -> None:
        while (item := self._queue.get()) is not None:
            if isinstance(item, threading.Event):
                item.set()
            elif self.failure is None:
                try:
                    self._write(item)
                except Exception as exc:  # the domain closed under us: stop writing, the rig goes on
                    self.failure = f"{type(exc).__name__}: {exc}"

    def flush(self, timeout_s: float = 2.0) -> bool:
        """Wait until the frames queued so far are written; whether they were within `timeout_s`."""
        if self._thread is None or not self._thread.is_alive():
            return True
        done = threading.Event()
        self._queue.put(done)
        return done.wait(timeout_s)

    def publish_calibration(self, Ps: NDArray[np.float64] | None) -> None:
        """`/tf_static`: link1 -> each camera (transient local: a late subscriber gets the last)."""
        if Ps is None:
            return
        stamp = now_stamp()
        data = tf_bytes([transform(T, self.frame_name, camera_frame(c), stamp) for c, T in enumerate(camera_poses(Ps))])
        with self._lock:
            _write_cdr(self._tf_static, data)

    def publish_throw(self, index: int, result: dict[str, Any]) -> int:
        return self.publish_throw_text(dumps_strict({"index": index, "result": result}))

    def publish_throw_text(self, text: str) -> int:
        """One throw already as its JSON text (`{"index", "result"}`: a writer process is handed it so)."""
        data = cdr.string(text)
        with self._lock:
            seq = self.throws_sent
            _write_cdr(self._throws, data)
            self.throws_sent += 1
            return seq

    def publish_transforms(self, transforms: Sequence[m.TransformStamped]) -> None:
        data = tf_bytes(transforms)
        with self._lock:
            _write_cdr(self._tf, data)
            self.tf_sent += 1

    def _sample_arm(self, stamp: m.Time) -> None:
        T = self._arm_samples.due()
        if T is not None:
            self.publish_transforms([transform(T, "base", "link1", stamp)])

    def dots_read(self) -> int:
        """Which cameras' dots have a matched reader now, as bits (camera c: bit c)."""
        return sum(1 << c for c, writer in enumerate(self._dots) if _has_reader(writer))

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

        self.flush(timeout_s)
        self._stop_thread()
        for writer in (self._throws, self._tf, self._tf_static):
            try:
                writer.wait_for_acks(duration(seconds=timeout_s))
            except Exception:  # no reader, or the domain is gone: nothing to wait for
                pass
        time.sleep(LINGER_S)

    def _stop_thread(self) -> None:
        thread, self._thread = self._thread, None
        if thread is not None:
            self._queue.put(None)
            thread.join(timeout=2.0)

    def announcement(self) -> str:
        return f"ROS 2 topics under {self.namespace or '/'} (and /tf, /tf_static) on DDS domain {self.domain.domain_id}"

    def summary(self) -> str:
        return (
            f"published {self.markers_sent} marker frames, {sum(self.dots_sent)} camera frames, {self.tf_sent} /tf "
            f"and {self.throws_sent} throws as ROS 2 topics under {self.namespace or '/'}"
            + (
                f" ({self.markers_dropped} marker and {self.dots_dropped} camera frames dropped: the writer was behind)"
                if self.markers_dropped or self.dots_dropped
                else ""
            )
            + (f"; writing stopped: {self.failure}" if self.failure else "")
        )
