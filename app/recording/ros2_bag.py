"""A recording as a ROS 2 bag: `write_ros2_bag`, what `wiithrow export` runs.

The bag is an MCAP file of the `ros2` profile, as rosbag2's MCAP storage writes one: for every
channel of the recording that has a ROS 2 form (`wiithrow.app.channels.registry`: the markers as
mocap4r2 `Markers` and a `MarkerArray`, each camera's dots as a `PointCloud`, `/tf`, `/tf_static`,
the joints as `JointState`, the previewed trajectories as `JointTrajectory`, the throws and the
robot description as `String`), a channel of that ROS 2 topic (the live publisher's name, under
`namespace`), encoding `cdr`, its schema the type's complete `ros2msg` definition
(`ros2_definitions.full_text`) and its offered QoS in rosbag2's YAML (`offered_qos_profiles`);
each message is the recorded JSON message encoded as the live publisher encodes it
(`ros2_messages`), with the recorded log time (its Unix time, `wall_time`) as its log time and its
headers' stamp. `ros2 bag info`/`play`, rosbags and `mcap-ros2-support` read it.

Why a second file, not the ROS 2 channels inside the recording: rosbags refuses an MCAP file with
any schema that is not a ROS 2 one (a JSON Schema: `KeyError: 'jsonschema'`), and rosbag2 keys a
bag's topics by name, so the recording's `/tf` (Foxglove's `FrameTransforms`, JSON) and ROS 2's
`/tf` (`TFMessage`, CDR) cannot both be in one file; the recording, which keeps every raw report,
stays the source the bag is made from (of any recording, format 1 included), and the rig's thread,
which writes the recording, pays for one encoding of each message, not two.
"""

from __future__ import annotations

import os
import tempfile
from collections import Counter
from pathlib import Path

from mcap.writer import CompressionType, Writer

import wiithrow
from wiithrow.app.channels import registry as r
from wiithrow.app.channels import ros2_messages
from wiithrow.app.channels.ros2_definitions import full_text
from wiithrow.app.channels.ros2_sink import DEFAULT_NAMESPACE
from wiithrow.app.recording.channels import RecordingError
from wiithrow.app.recording.reading import Recording
from wiithrow.app.ros2.domain import ros_name, topic_name
from wiithrow.vision.errors import FileFormatError

PROFILE = "ros2"
CHUNK_BYTES = 1024 * 1024


def qos_yaml(qos: r.Qos) -> str:
    """A topic's offered QoS as rosbag2 writes it in a channel's `offered_qos_profiles` (rmw's
    enums: KEEP_LAST 1; RELIABLE 1, BEST_EFFORT 2; TRANSIENT_LOCAL 1, VOLATILE 2; AUTOMATIC 1;
    durations 0: the default, infinite)."""
    zero = "\n    sec: 0\n    nsec: 0"
    return (
        f"- history: 1\n  depth: {qos.depth}\n  reliability: {1 if qos.reliable else 2}\n"
        f"  durability: {1 if qos.transient_local else 2}\n  deadline:{zero}\n  lifespan:{zero}\n"
        f"  liveliness: 1\n  liveliness_lease_duration:{zero}\n  avoid_ros_namespace_conventions: false\n"
    )


def ros2_topic(form: r.Ros2Form, namespace: str, camera_name: str | None = None) -> str:
    """The ROS 2 name of a channel's form (a camera's, with its name as one ROS 2 name token)."""
    name = form.topic if camera_name is None else form.topic.format(name=ros_name(camera_name))
    return topic_name(namespace, name)[2:]  # the DDS topic without its "rt"


def write_ros2_bag(
    recording: Recording, out: str | os.PathLike[str], *, namespace: str = DEFAULT_NAMESPACE
) -> tuple[Counter[str], str | None]:
    """Write `recording`'s channels that have a ROS 2 form to `out` as a ROS 2 bag (module
    docstring), as far as the recording is intact: how many messages each ROS 2 topic got, and
    where a damaged recording ended (None: intact). `out` is written whole or not at all (a
    temporary file beside it, renamed at the end)."""
    out = Path(out)
    counts: Counter[str] = Counter()
    names = recording.camera_names
    fd, temporary = tempfile.mkstemp(prefix=f".{out.name}.", dir=out.parent)
    try:
        with os.fdopen(fd, "wb") as f:
            writer = Writer(f, chunk_size=CHUNK_BYTES, compression=CompressionType.ZSTD)
            writer.start(profile=PROFILE, library=f"wiithrow {wiithrow.__version__}")
            schemas: dict[str, int] = {}
            channels: dict[str, int] = {}

            def channel_id(topic: str, form: r.Ros2Form) -> int:
                if topic not in channels:
                    if form.type not in schemas:
                        schemas[form.type] = writer.register_schema(form.type, "ros2msg", full_text(form.type).encode())
                    metadata = {"offered_qos_profiles": qos_yaml(form.qos)}
                    channels[topic] = writer.register_channel(topic, "cdr", schemas[form.type], metadata)
                return channels[topic]

            with recording.messages() as stream:
                for recorded in stream:
                    channel = r.channel_of(recorded.topic)
                    if channel is None or not channel.ros2:
                        continue
                    camera = names[r.camera_of(recorded.topic)] if channel.per_camera else None
                    try:
                        message = recorded.json()
                        for form in channel.ros2:
                            topic = ros2_topic(form, namespace, camera)
                            data = ros2_messages.encode(form.type, message, recorded.log_time, counts[topic])
                            writer.add_message(
                                channel_id(topic, form), recorded.log_time, data, recorded.log_time, counts[topic]
                            )
                            counts[topic] += 1
                    except (FileFormatError, KeyError, TypeError, ValueError, IndexError) as exc:
                        raise RecordingError(
                            f"{recording.path}: a {recorded.topic} message at log time {recorded.log_time} does not "
                            f"fit its channel ({type(exc).__name__}: {exc}): no bag written"
                        ) from None
                end = stream.end
            writer.finish()
        os.replace(temporary, out)
    except BaseException:
        Path(temporary).unlink(missing_ok=True)
        raise
    return counts, end
