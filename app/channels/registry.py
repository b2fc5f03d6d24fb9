"""Every channel wiithrow produces, defined once: its topic, what it means, its JSON Schema, its ROS 2
forms (topic, message type, QoS), its Zenoh key, and whether its last message is latched.

The sinks take their names and types from here: a recording and Foxglove live write the JSON
message of `topic` with `schema` (`json_messages` builds it, `json_schemas` describes it); the ROS 2
publisher and a ROS 2 bag write each of `ros2`'s forms (`ros2_messages` encodes the JSON message as
that type's CDR, `ros2_definitions` holds the type's `.msg` text); the Zenoh publisher puts the
channels that have a `zenoh` key (`wiithrow.app.network.messages`: its payloads). A channel that
is `latched` is state rather than a stream: its last message is what a newcomer needs (the
cameras' frames, the calibration, the arm's description), so Foxglove live sends it again to every
client that subscribes, and its ROS 2 form is transient-local where ROS 2's conventions make it so
(`/tf_static`, `robot_description`: a late subscriber gets it from the writer).

Per-camera channels (`per_camera`) hold `{camera}` in their topic (the camera's index, 0..C-1) and
`{name}` in their ROS 2 topic and Zenoh key (the camera's name, as one ROS 2 name token).

QoS (`Qos`) is ROS 2's: the sensor-data profile (`rmw_qos_profile_sensor_data`: best effort, keep
last 5, volatile) for what streams at the rig's rate, tf2's broadcaster (reliable, keep last 100)
for `/tf`, the static broadcaster's and robot_state_publisher's (reliable, transient local, keep
last 1) for `/tf_static` and `robot_description`, ROS 2's default (reliable, keep last 10) for
the rest.
"""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class Qos:
    """A ROS 2 topic's delivery: reliable or best effort, transient local or volatile, keep last `depth`."""

    reliable: bool
    transient_local: bool
    depth: int


SENSOR_DATA_QOS = Qos(reliable=False, transient_local=False, depth=5)
DEFAULT_QOS = Qos(reliable=True, transient_local=False, depth=10)
TF_QOS = Qos(reliable=True, transient_local=False, depth=100)
LATCHED_QOS = Qos(reliable=True, transient_local=True, depth=1)


@dataclass(frozen=True)
class Ros2Form:
    """A channel as one ROS 2 topic: `topic` relative to the publisher's namespace (or absolute,
    '/tf'), `type` the ROS 2 message type (`pkg/msg/Name`), `qos` its delivery."""

    topic: str
    type: str
    qos: Qos


@dataclass(frozen=True)
class Channel:
    """One channel (module docstring)."""

    name: str
    topic: str
    meaning: str
    schema: str
    ros2: tuple[Ros2Form, ...] = ()
    zenoh: str | None = None
    latched: bool = False
    per_camera: bool = False

    def topic_of(self, camera: int | None = None) -> str:
        """The recording's and Foxglove's topic (a camera's, for a per-camera channel)."""
        return self.topic.format(camera=camera) if self.per_camera else self.topic


REPORTS = Channel(
    "reports",
    "/wiimote/{camera}/reports",
    "the raw HID input reports of remote c as the driver decoded them (a batch read back to back), each with "
    "the host's receive time: the complete source a replay tracks again",
    "wiithrow.HidReports",
    per_camera=True,
)
DOTS = Channel(
    "dots",
    "/wiimote/{camera}/dots",
    "camera c's frames: its four dots in pixels (an empty slot null)",
    "wiithrow.Dots",
    ros2=(Ros2Form("cameras/{name}/dots", "sensor_msgs/msg/PointCloud", SENSOR_DATA_QOS),),
    zenoh="cameras/{name}/dots",
    per_camera=True,
)
STEPS = Channel(
    "steps",
    "/rig/steps",
    "what the rig did with the frames (frames processed, flushes): with the reports, what a replay repeats",
    "wiithrow.RigStep",
)
TRACKING_START = Channel(
    "start",
    "/rig/start",
    "when the command started tracking, on the rig's clock: what `replay`'s rows count t from",
    "wiithrow.TrackingStart",
)
MARKERS = Channel(
    "markers",
    "/markers",
    "each tracked frame: the markers with their track ids, in the calibration's frame (m); predicted ones too",
    "wiithrow.Markers",
    ros2=(
        Ros2Form("markers", "mocap4r2_msgs/msg/Markers", SENSOR_DATA_QOS),
        Ros2Form("markers/visualization", "visualization_msgs/msg/MarkerArray", SENSOR_DATA_QOS),
    ),
    zenoh="markers",
)
SCENE = Channel(
    "scene",
    "/markers/scene",
    "the markers as Foxglove's 3D panel draws them: a sphere and its id per marker, 20 Hz",
    "foxglove.SceneUpdate",
)
CALIBRATION = Channel(
    "calibration",
    "/calibration",
    "the projection matrices in use, at the start and at every change",
    "wiithrow.Calibration",
    latched=True,
)
TF = Channel(
    "tf",
    "/tf",
    "the frames that move: base -> link1 (joint 1) of a session's arm",
    "foxglove.FrameTransforms",
    ros2=(Ros2Form("/tf", "tf2_msgs/msg/TFMessage", TF_QOS),),
    latched=True,
)
TF_STATIC = Channel(
    "tf_static",
    "/tf_static",
    "the frames that stand: the calibration's frame -> each camera (camera_c, z forward), at every calibration",
    "foxglove.FrameTransforms",
    ros2=(Ros2Form("/tf_static", "tf2_msgs/msg/TFMessage", LATCHED_QOS),),
    latched=True,
)
JOINTS = Channel(
    "joints",
    "/arm/joints",
    "a session's arm: its measured joints (rad, rad/s), at most 50 Hz",
    "wiithrow.JointState",
    ros2=(Ros2Form("joint_states", "sensor_msgs/msg/JointState", DEFAULT_QOS),),
)
TRAJECTORY = Channel(
    "trajectory",
    "/arm/trajectory",
    "each previewed throw's commanded trajectory",
    "wiithrow.Trajectory",
    ros2=(Ros2Form("arm/trajectory", "trajectory_msgs/msg/JointTrajectory", DEFAULT_QOS),),
)
THROWS = Channel(
    "throws",
    "/throws",
    "each executed throw: its plan, release, landing and error (and its landing again once measured)",
    "wiithrow.Throw",
    ros2=(Ros2Form("throws", "std_msgs/msg/String", DEFAULT_QOS),),
    zenoh="throws",
)
ROBOT_DESCRIPTION = Channel(
    "robot_description",
    "/robot_description",
    "a session's arm as its URDF (what robot_state_publisher and Foxglove's URDF layer read)",
    "std_msgs/msg/String",
    ros2=(Ros2Form("robot_description", "std_msgs/msg/String", LATCHED_QOS),),
    latched=True,
)

#: Every channel, in the order a file or a server lists them.
CHANNELS: tuple[Channel, ...] = (
    REPORTS,
    DOTS,
    STEPS,
    TRACKING_START,
    MARKERS,
    SCENE,
    CALIBRATION,
    TF,
    TF_STATIC,
    JOINTS,
    TRAJECTORY,
    THROWS,
    ROBOT_DESCRIPTION,
)
#: What a rig's events write (a recording of `track`, Foxglove live of a rig).
RIG_CHANNELS = (REPORTS, DOTS, STEPS, MARKERS, SCENE, CALIBRATION, TF_STATIC)
#: What a session adds to its rig's.
SESSION_CHANNELS = (JOINTS, TF, TRAJECTORY, THROWS, ROBOT_DESCRIPTION)

_BY_TOPIC = {c.topic: c for c in CHANNELS if not c.per_camera}


def channel_of(topic: str) -> Channel | None:
    """The channel of a recording's or Foxglove's topic (None: not one of ours)."""
    channel = _BY_TOPIC.get(topic)
    if channel is not None:
        return channel
    parts = topic.split("/")  # /wiimote/<c>/<kind>
    if len(parts) == 4 and parts[1] == "wiimote" and parts[2].isdigit():
        return {"reports": REPORTS, "dots": DOTS}.get(parts[3])
    return None


def camera_of(topic: str) -> int:
    """The camera index of a per-camera topic (`/wiimote/<c>/...`)."""
    return int(topic.split("/")[2])


def topics(channels: tuple[Channel, ...], cameras: int) -> list[str]:
    """The topics of `channels` for a rig of `cameras` cameras."""
    out = []
    for channel in channels:
        out += [channel.topic_of(c) for c in range(cameras)] if channel.per_camera else [channel.topic]
    return out
