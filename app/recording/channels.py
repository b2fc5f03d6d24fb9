"""What a recording is: its format version, profile and metadata, and its topics.

A recording is an MCAP file of the channels' JSON messages (`wiithrow.app.channels.registry`:
every topic, its meaning and its JSON Schema, defined there once; `mcap_sink` writes them), so
Foxglove and the `mcap` tools read it without a plugin. The file's header names the profile
"wiithrow", and a metadata record `wiithrow` holds `format_version` (a reader refuses a file from
a newer version), the rig's `cameras` and `camera_names`, `unix_offset_ns` (the rig's clock mapped
to Unix time: a message's log time is `round(t * 1e9) + unix_offset_ns`, `wall_time`) and the
`digest` of its entries.

Format 2 (this one): log times are Unix time, the cameras' frames are on `/tf_static`, a session's
base -> link1 on `/tf`, its URDF on `/robot_description`. Format 1 (read as well): log times were
the rig's clock (`unix_offset_ns` absent: 0), the cameras were on `/tf`.

A throw's message (`/throws`) holds its record, whose `outcome` has the 3D error along / across /
height / total (`error`, `true_error`: `json_schemas.LANDING_ERROR`): fields added to the schema,
the format's version unchanged, so that a reader of the earlier files reads these and an earlier
reader these.

A recording is not a ROS 2 bag: `wiithrow.app.recording.ros2_bag` writes one from it (docs/integrations/recording.md:
why a second file).
"""

from __future__ import annotations

import json
import zlib

from wiithrow.app.channels import registry as r
from wiithrow.app.errors import AppError

#: This writer's format; a reader refuses files whose version is higher.
FORMAT_VERSION = 2
PROFILE = "wiithrow"
METADATA_NAME = "wiithrow"
CALIBRATION_ATTACHMENT = "calibration.json"

# The topics, as the recording's readers name them (defined in the registry).
STEPS = r.STEPS.topic
TRACKING_START = r.TRACKING_START.topic
MARKERS = r.MARKERS.topic
MARKERS_SCENE = r.SCENE.topic
CALIBRATION = r.CALIBRATION.topic
TF = r.TF.topic
TF_STATIC = r.TF_STATIC.topic
JOINTS = r.JOINTS.topic
TRAJECTORY = r.TRAJECTORY.topic
THROWS = r.THROWS.topic
ROBOT_DESCRIPTION = r.ROBOT_DESCRIPTION.topic


class RecordingError(AppError):
    """A recording that cannot be written or read (one line for the command line)."""


def digest(metadata: dict[str, str]) -> str:
    """A CRC-32 of the metadata's other entries: MCAP keeps no checksum of metadata records."""
    entries = {k: v for k, v in metadata.items() if k != "digest"}
    return f"{zlib.crc32(json.dumps(entries, sort_keys=True).encode()):08x}"


def reports_topic(camera: int) -> str:
    return r.REPORTS.topic_of(camera)


def dots_topic(camera: int) -> str:
    return r.DOTS.topic_of(camera)


def schema_of(topic: str) -> str:
    """The schema name of a topic (KeyError: not one of the channels)."""
    channel = r.channel_of(topic)
    if channel is None:
        raise KeyError(topic)
    return channel.schema
