"""The ROS 2 messages wiithrow publishes, as Cyclone DDS types that mirror ROS 2's definitions.

What the ROS 2 publisher's DDS topics are typed with (`BY_TYPE`); its samples are packed by hand
(`wiithrow.app.channels.cdr`), byte for byte what these classes serialize to.

Each class is the DDS form of one ROS 2 message, field for field in the order of its `.msg` file
(ROS 2 Humble and later; `idl/` ships the same types as IDL, as `rosidl_generator_dds_idl`
writes them, for a subscriber that has no package of ours). The DDS type name of ROS 2 message
`pkg/msg/Name` is `pkg::msg::dds_::Name_` (`typename`); a ROS 2 node on any DDS middleware
(rmw_cyclonedds, rmw_fastrtps) matches a topic by that name, and reads the samples in CDR
(XCDR1, little endian: `qos.ros2_qos` asks for it), which these classes serialize to.

The ROS 2 types ->  wire types map (.msg -> IDL -> Python): int8/int32/uint32 -> `types.int8`...,
float32 -> `types.float32`, float64 -> float, bool -> bool, string -> str (CDR: uint32 length with
the terminating NUL, the bytes, the NUL), T[] -> `types.sequence[T]` (uint32 count, then the items).

mocap4r2_msgs (Markers: the points with ids, how mocap systems reach ROS 2, MOCAP4ROS2 project,
REP draft "Motion Capture Systems") is not in a ROS 2 distribution: its IDL is in `idl/`.
"""

# (no `from __future__ import annotations`: cyclonedds reads the annotations as objects)
from dataclasses import dataclass, field

from cyclonedds.idl import IdlStruct, types


def _name(package: str, message: str) -> str:
    """The DDS type name of ROS 2 message `package/msg/message` (dots: cyclonedds writes '::')."""
    return f"{package}.msg.dds_.{message}_"


# -- builtin_interfaces, std_msgs


@dataclass
class Time(IdlStruct, typename=_name("builtin_interfaces", "Time")):
    sec: types.int32 = 0
    nanosec: types.uint32 = 0


@dataclass
class Duration(IdlStruct, typename=_name("builtin_interfaces", "Duration")):
    sec: types.int32 = 0
    nanosec: types.uint32 = 0


@dataclass
class Header(IdlStruct, typename=_name("std_msgs", "Header")):
    stamp: Time = field(default_factory=Time)
    frame_id: str = ""


@dataclass
class ColorRGBA(IdlStruct, typename=_name("std_msgs", "ColorRGBA")):
    r: types.float32 = 0.0
    g: types.float32 = 0.0
    b: types.float32 = 0.0
    a: types.float32 = 0.0


@dataclass
class String(IdlStruct, typename=_name("std_msgs", "String")):
    data: str = ""


# -- geometry_msgs


@dataclass
class Point(IdlStruct, typename=_name("geometry_msgs", "Point")):
    x: float = 0.0
    y: float = 0.0
    z: float = 0.0


@dataclass
class Point32(IdlStruct, typename=_name("geometry_msgs", "Point32")):
    x: types.float32 = 0.0
    y: types.float32 = 0.0
    z: types.float32 = 0.0


@dataclass
class Vector3(IdlStruct, typename=_name("geometry_msgs", "Vector3")):
    x: float = 0.0
    y: float = 0.0
    z: float = 0.0


@dataclass
class Quaternion(IdlStruct, typename=_name("geometry_msgs", "Quaternion")):
    x: float = 0.0
    y: float = 0.0
    z: float = 0.0
    w: float = 1.0


@dataclass
class Pose(IdlStruct, typename=_name("geometry_msgs", "Pose")):
    position: Point = field(default_factory=Point)
    orientation: Quaternion = field(default_factory=Quaternion)


@dataclass
class Transform(IdlStruct, typename=_name("geometry_msgs", "Transform")):
    translation: Vector3 = field(default_factory=Vector3)
    rotation: Quaternion = field(default_factory=Quaternion)


@dataclass
class TransformStamped(IdlStruct, typename=_name("geometry_msgs", "TransformStamped")):
    header: Header = field(default_factory=Header)
    child_frame_id: str = ""
    transform: Transform = field(default_factory=Transform)


# -- tf2_msgs


@dataclass
class TFMessage(IdlStruct, typename=_name("tf2_msgs", "TFMessage")):
    transforms: types.sequence[TransformStamped] = field(default_factory=list)


# -- sensor_msgs


@dataclass
class CompressedImage(IdlStruct, typename=_name("sensor_msgs", "CompressedImage")):
    header: Header = field(default_factory=Header)
    format: str = ""
    data: types.sequence[types.uint8] = field(default_factory=list)


@dataclass
class ChannelFloat32(IdlStruct, typename=_name("sensor_msgs", "ChannelFloat32")):
    name: str = ""
    values: types.sequence[types.float32] = field(default_factory=list)


@dataclass
class PointCloud(IdlStruct, typename=_name("sensor_msgs", "PointCloud")):
    header: Header = field(default_factory=Header)
    points: types.sequence[Point32] = field(default_factory=list)
    channels: types.sequence[ChannelFloat32] = field(default_factory=list)


@dataclass
class JointState(IdlStruct, typename=_name("sensor_msgs", "JointState")):
    header: Header = field(default_factory=Header)
    name: types.sequence[str] = field(default_factory=list)
    position: types.sequence[float] = field(default_factory=list)
    velocity: types.sequence[float] = field(default_factory=list)
    effort: types.sequence[float] = field(default_factory=list)


# -- trajectory_msgs


@dataclass
class JointTrajectoryPoint(IdlStruct, typename=_name("trajectory_msgs", "JointTrajectoryPoint")):
    positions: types.sequence[float] = field(default_factory=list)
    velocities: types.sequence[float] = field(default_factory=list)
    accelerations: types.sequence[float] = field(default_factory=list)
    effort: types.sequence[float] = field(default_factory=list)
    time_from_start: Duration = field(default_factory=Duration)


@dataclass
class JointTrajectory(IdlStruct, typename=_name("trajectory_msgs", "JointTrajectory")):
    header: Header = field(default_factory=Header)
    joint_names: types.sequence[str] = field(default_factory=list)
    points: types.sequence[JointTrajectoryPoint] = field(default_factory=list)


# -- visualization_msgs (Marker as of Humble: texture, uv_coordinates and mesh_file included)


@dataclass
class UVCoordinate(IdlStruct, typename=_name("visualization_msgs", "UVCoordinate")):
    u: types.float32 = 0.0
    v: types.float32 = 0.0


@dataclass
class MeshFile(IdlStruct, typename=_name("visualization_msgs", "MeshFile")):
    filename: str = ""
    data: types.sequence[types.uint8] = field(default_factory=list)


#: visualization_msgs/Marker's constants used here.
SPHERE = 2
TEXT_VIEW_FACING = 9
ADD = 0
DELETEALL = 3


@dataclass
class Marker(IdlStruct, typename=_name("visualization_msgs", "Marker")):
    header: Header = field(default_factory=Header)
    ns: str = ""
    id: types.int32 = 0
    type: types.int32 = 0
    action: types.int32 = 0
    pose: Pose = field(default_factory=Pose)
    scale: Vector3 = field(default_factory=Vector3)
    color: ColorRGBA = field(default_factory=ColorRGBA)
    lifetime: Duration = field(default_factory=Duration)
    frame_locked: bool = False
    points: types.sequence[Point] = field(default_factory=list)
    colors: types.sequence[ColorRGBA] = field(default_factory=list)
    texture_resource: str = ""
    texture: CompressedImage = field(default_factory=CompressedImage)
    uv_coordinates: types.sequence[UVCoordinate] = field(default_factory=list)
    text: str = ""
    mesh_resource: str = ""
    mesh_file: MeshFile = field(default_factory=MeshFile)
    mesh_use_embedded_materials: bool = False


@dataclass
class MarkerArray(IdlStruct, typename=_name("visualization_msgs", "MarkerArray")):
    markers: types.sequence[Marker] = field(default_factory=list)


# -- mocap4r2_msgs (idl/mocap4r2_msgs.idl)

#: mocap4r2_msgs/Marker's id_type values.
USE_NAME = 0
USE_INDEX = 1
USE_BOTH = 2


@dataclass
class MocapMarker(IdlStruct, typename=_name("mocap4r2_msgs", "Marker")):
    id_type: types.int8 = USE_INDEX
    marker_index: types.int32 = 0
    marker_name: str = ""
    translation: Point = field(default_factory=Point)


@dataclass
class MocapMarkers(IdlStruct, typename=_name("mocap4r2_msgs", "Markers")):
    header: Header = field(default_factory=Header)
    frame_number: types.uint32 = 0
    markers: types.sequence[MocapMarker] = field(default_factory=list)


#: Each ROS 2 message type (`pkg/msg/Name`) a channel is published as, and its DDS type.
BY_TYPE: dict[str, type[IdlStruct]] = {
    "mocap4r2_msgs/msg/Markers": MocapMarkers,
    "visualization_msgs/msg/MarkerArray": MarkerArray,
    "sensor_msgs/msg/PointCloud": PointCloud,
    "tf2_msgs/msg/TFMessage": TFMessage,
    "sensor_msgs/msg/JointState": JointState,
    "trajectory_msgs/msg/JointTrajectory": JointTrajectory,
    "std_msgs/msg/String": String,
}


def stamp(t_ns: int) -> Time:
    """A builtin_interfaces/Time of `t_ns` nanoseconds (sec may be negative, nanosec in [0, 1e9))."""
    sec, nanosec = divmod(int(t_ns), 1_000_000_000)
    return Time(sec=sec, nanosec=nanosec)
