"""The channels' ROS 2 forms: each JSON message (`json_messages`) as the CDR of its ROS 2 type.

One encoder per ROS 2 type a channel has (`registry.Ros2Form.type`), `encode(type, message,
stamp_ns, seq)`: the live ROS 2 publisher and a ROS 2 bag write the same bytes for the same
message. `stamp_ns` is the message's Unix time (its headers' `stamp`); `seq` the frame's number
(mocap4r2's `frame_number`). What each holds:

| type | from the JSON message |
|---|---|
| mocap4r2_msgs/Markers | a Marker per track: `marker_index` its id (`id_type` USE_INDEX), `translation` its position (m) in `frame_id` |
| visualization_msgs/MarkerArray | RViz's view: DELETEALL, then per track a 3 cm sphere (`id` the track's; orange seen, grey predicted) and its id as text (ns `wiithrow/ids`) |
| sensor_msgs/PointCloud | a camera frame's seen dots as points (x = u, y = v in pixels, z = 0), channel `slot` their slot 0-3; `frame_id` camera_c |
| tf2_msgs/TFMessage | the FrameTransforms, transform for transform (their own stamps) |
| sensor_msgs/JointState | `name`, `position` (rad), `velocity` (rad/s); no effort |
| trajectory_msgs/JointTrajectory | the joints' names, a point per time: positions, `time_from_start` from the first; `frame_id` base |
| std_msgs/String | a throw: its document as JSON; the robot description: its URDF |
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

from wiithrow.app.channels import cdr
from wiithrow.app.channels.json_messages import LABEL_ABOVE_M, MARKER_SIZE_M, PREDICTED, SEEN, camera_frame
from wiithrow.app.channels.wall_time import NS_PER_S
from wiithrow.vision.files import dumps_strict

#: visualization_msgs/Marker's constants used here.
SPHERE, TEXT_VIEW_FACING, ADD, DELETEALL = 2, 9, 0, 3
#: mocap4r2_msgs/Marker's id_type: the track id is the marker's index.
USE_INDEX = 1
#: JointTrajectory's frame: joint space, of the arm's base.
TRAJECTORY_FRAME = "base"


def _rgba(color: dict[str, float]) -> tuple[float, float, float, float]:
    return (color["r"], color["g"], color["b"], color["a"])


_SEEN, _PREDICTED = _rgba(SEEN), _rgba(PREDICTED)
_SPHERE_SCALE = (MARKER_SIZE_M, MARKER_SIZE_M, MARKER_SIZE_M)
_TEXT_SCALE = (0.0, 0.0, 0.03)
_ZERO_POSE = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0)
_DELETE_ALL: cdr.MarkerSpec = (0, 0, DELETEALL, _ZERO_POSE, (0.0, 0.0, 0.0), (0.0, 0.0, 0.0, 0.0), "")


def _sec_nanosec(stamp_ns: int) -> tuple[int, int]:
    sec, nanosec = divmod(stamp_ns, NS_PER_S)
    return sec, nanosec


def mocap_markers(message: dict[str, Any], stamp_ns: int, seq: int) -> bytes:
    sec, nanosec = _sec_nanosec(stamp_ns)
    return cdr.mocap_markers(sec, nanosec, message["frame_id"], seq, message["ids"], message["positions"])


def marker_array(message: dict[str, Any], stamp_ns: int, seq: int = 0) -> bytes:
    sec, nanosec = _sec_nanosec(stamp_ns)
    markers: list[tuple[str, cdr.MarkerSpec]] = [("wiithrow/markers", _DELETE_ALL)]
    for i, (x, y, z), seen in zip(message["ids"], message["positions"], message["visible"]):
        color = _SEEN if seen else _PREDICTED
        markers.append(("wiithrow/markers", (i, SPHERE, ADD, (x, y, z, 0.0, 0.0, 0.0, 1.0), _SPHERE_SCALE, color, "")))
        label = (x, y, z + LABEL_ABOVE_M, 0.0, 0.0, 0.0, 1.0)
        markers.append(("wiithrow/ids", (i, TEXT_VIEW_FACING, ADD, label, _TEXT_SCALE, color, str(i))))
    return cdr.marker_array(sec, nanosec, message["frame_id"], markers)


def point_cloud(message: dict[str, Any], stamp_ns: int, seq: int = 0) -> bytes:
    sec, nanosec = _sec_nanosec(stamp_ns)
    points, slots = [], []
    for slot, dot in enumerate(message["dots"]):
        if dot is not None and math.isfinite(dot[0]) and math.isfinite(dot[1]):
            points.append((dot[0], dot[1], 0.0))
            slots.append(float(slot))
    return cdr.point_cloud(sec, nanosec, camera_frame(message["camera"]), points, [("slot", slots)])


def tf_message(message: dict[str, Any], stamp_ns: int = 0, seq: int = 0) -> bytes:
    transforms = []
    for t in message["transforms"]:
        p, r = t["translation"], t["rotation"]
        stamp = t["timestamp"]
        transforms.append(
            (
                stamp["sec"],
                stamp["nsec"],
                t["parent_frame_id"],
                t["child_frame_id"],
                (p["x"], p["y"], p["z"]),
                (r["x"], r["y"], r["z"], r["w"]),
            )
        )
    return cdr.tf_message(transforms)


def joint_state(message: dict[str, Any], stamp_ns: int, seq: int = 0) -> bytes:
    sec, nanosec = _sec_nanosec(stamp_ns)
    return cdr.joint_state(sec, nanosec, "", message.get("names", []), message["q"], message["dq"])


def joint_trajectory(message: dict[str, Any], stamp_ns: int, seq: int = 0) -> bytes:
    sec, nanosec = _sec_nanosec(stamp_ns)
    times = message["times"]
    start = times[0] if times else 0.0
    points: list[cdr.PointSpec] = []
    for t, q in zip(times, message["q"]):
        at_sec, at_nanosec = divmod(round((t - start) * NS_PER_S), NS_PER_S)
        points.append((q, (), at_sec, at_nanosec))
    return cdr.joint_trajectory(sec, nanosec, TRAJECTORY_FRAME, message.get("names", []), points)


def string(message: dict[str, Any], stamp_ns: int = 0, seq: int = 0) -> bytes:
    """std_msgs/String: a robot description's `data`, else the message's `record` as JSON (a throw)."""
    text = message["data"] if "data" in message else dumps_strict(message["record"])
    return cdr.string(text)


ENCODERS: dict[str, Callable[[dict[str, Any], int, int], bytes]] = {
    "mocap4r2_msgs/msg/Markers": mocap_markers,
    "visualization_msgs/msg/MarkerArray": marker_array,
    "sensor_msgs/msg/PointCloud": point_cloud,
    "tf2_msgs/msg/TFMessage": tf_message,
    "sensor_msgs/msg/JointState": joint_state,
    "trajectory_msgs/msg/JointTrajectory": joint_trajectory,
    "std_msgs/msg/String": string,
}


def encode(type_name: str, message: dict[str, Any], stamp_ns: int, seq: int = 0) -> bytes:
    """The CDR of `message` (a channel's JSON message) as ROS 2 type `type_name`."""
    return ENCODERS[type_name](message, stamp_ns, seq)
