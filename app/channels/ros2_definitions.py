"""The ROS 2 message definitions of the channels' ROS 2 types, as `.msg` text: what a ROS 2 bag
stores beside each topic (MCAP's `ros2msg` schema encoding) so that a reader without the packages
decodes it.

`DEFINITIONS` holds each type's own `.msg` fields and constants (ROS 2 Humble's, comments left
out; mocap4r2_msgs' from its package's `msg/` folder: no ROS 2 distribution ships it), field types
named `pkg/Name` as the `.msg` files name them. `full_text(type)` is what rosbag2's MCAP storage
writes as a schema's data (rosbag2_storage_mcap, `MessageDefinitionCache::get_full_text`): the
type's own text, then each type it uses, depth first, in sorted order, each once, after a line of
80 `=` and a line `MSG: pkg/Name`. The same types' DDS forms are `wiithrow.app.ros2.messages`.
"""

from __future__ import annotations

import re

_TIME = "int32 sec\nuint32 nanosec"

_MARKER = """\
int32 ARROW=0
int32 CUBE=1
int32 SPHERE=2
int32 CYLINDER=3
int32 LINE_STRIP=4
int32 LINE_LIST=5
int32 CUBE_LIST=6
int32 SPHERE_LIST=7
int32 POINTS=8
int32 TEXT_VIEW_FACING=9
int32 MESH_RESOURCE=10
int32 TRIANGLE_LIST=11
int32 ADD=0
int32 MODIFY=0
int32 DELETE=2
int32 DELETEALL=3
std_msgs/Header header
string ns
int32 id
int32 type
int32 action
geometry_msgs/Pose pose
geometry_msgs/Vector3 scale
std_msgs/ColorRGBA color
builtin_interfaces/Duration lifetime
bool frame_locked
geometry_msgs/Point[] points
std_msgs/ColorRGBA[] colors
string texture_resource
sensor_msgs/CompressedImage texture
visualization_msgs/UVCoordinate[] uv_coordinates
string text
string mesh_resource
visualization_msgs/MeshFile mesh_file
bool mesh_use_embedded_materials"""

#: pkg/Name -> its .msg text.
DEFINITIONS: dict[str, str] = {
    "builtin_interfaces/Time": _TIME,
    "builtin_interfaces/Duration": _TIME,
    "std_msgs/Header": "builtin_interfaces/Time stamp\nstring frame_id",
    "std_msgs/String": "string data",
    "std_msgs/ColorRGBA": "float32 r\nfloat32 g\nfloat32 b\nfloat32 a",
    "geometry_msgs/Point": "float64 x\nfloat64 y\nfloat64 z",
    "geometry_msgs/Point32": "float32 x\nfloat32 y\nfloat32 z",
    "geometry_msgs/Vector3": "float64 x\nfloat64 y\nfloat64 z",
    "geometry_msgs/Quaternion": "float64 x 0\nfloat64 y 0\nfloat64 z 0\nfloat64 w 1",
    "geometry_msgs/Pose": "geometry_msgs/Point position\ngeometry_msgs/Quaternion orientation",
    "geometry_msgs/Transform": "geometry_msgs/Vector3 translation\ngeometry_msgs/Quaternion rotation",
    "geometry_msgs/TransformStamped": (
        "std_msgs/Header header\nstring child_frame_id\ngeometry_msgs/Transform transform"
    ),
    "tf2_msgs/TFMessage": "geometry_msgs/TransformStamped[] transforms",
    "sensor_msgs/ChannelFloat32": "string name\nfloat32[] values",
    "sensor_msgs/PointCloud": (
        "std_msgs/Header header\ngeometry_msgs/Point32[] points\nsensor_msgs/ChannelFloat32[] channels"
    ),
    "sensor_msgs/CompressedImage": "std_msgs/Header header\nstring format\nuint8[] data",
    "sensor_msgs/JointState": (
        "std_msgs/Header header\nstring[] name\nfloat64[] position\nfloat64[] velocity\nfloat64[] effort"
    ),
    "trajectory_msgs/JointTrajectoryPoint": (
        "float64[] positions\nfloat64[] velocities\nfloat64[] accelerations\nfloat64[] effort\n"
        "builtin_interfaces/Duration time_from_start"
    ),
    "trajectory_msgs/JointTrajectory": (
        "std_msgs/Header header\nstring[] joint_names\ntrajectory_msgs/JointTrajectoryPoint[] points"
    ),
    "visualization_msgs/UVCoordinate": "float32 u\nfloat32 v",
    "visualization_msgs/MeshFile": "string filename\nuint8[] data",
    "visualization_msgs/Marker": _MARKER,
    "visualization_msgs/MarkerArray": "visualization_msgs/Marker[] markers",
    "mocap4r2_msgs/Marker": (
        "int8 USE_NAME=0\nint8 USE_INDEX=1\nint8 USE_BOTH=2\n"
        "int8 id_type\nint32 marker_index\nstring marker_name\ngeometry_msgs/Point translation"
    ),
    "mocap4r2_msgs/Markers": "std_msgs/Header header\nuint32 frame_number\nmocap4r2_msgs/Marker[] markers",
}

_SEPARATOR = "=" * 80
_FIELD_TYPE = re.compile(r"^\s*([A-Za-z0-9_]+/[A-Za-z0-9_]+)(?:\[[^\]]*\])?\s+", re.MULTILINE)


def short_name(type_name: str) -> str:
    """`pkg/msg/Name` -> `pkg/Name` (a name already short is returned as it is)."""
    package, _, name = type_name.rpartition("/")
    return f"{package.split('/')[0]}/{name}"


def dependencies(type_name: str) -> list[str]:
    """The types a type's fields use, sorted (`pkg/Name`)."""
    return sorted(set(_FIELD_TYPE.findall(DEFINITIONS[short_name(type_name)])))


def full_text(type_name: str) -> str:
    """The complete `ros2msg` definition of `type_name` (`pkg/msg/Name`: module docstring)."""
    root = short_name(type_name)
    parts = [DEFINITIONS[root]]
    seen = {root}

    def append(dependency: str) -> None:
        parts.append(f"{_SEPARATOR}\nMSG: {dependency}\n{DEFINITIONS[dependency]}")
        for each in dependencies(dependency):
            if each not in seen:
                seen.add(each)
                append(each)

    for each in dependencies(root):
        if each not in seen:
            seen.add(each)
            append(each)
    return "\n".join(parts)
