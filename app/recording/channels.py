"""What a recording holds: its format version, its topics and their JSON schemas.

Every message is JSON (MCAP message encoding "json") with a JSON Schema, so Foxglove and the
`mcap` tools read the file without a plugin. The frames use Foxglove's well-known
`foxglove.FrameTransforms` (Foxglove draws them in 3D); the rest are wiithrow's own schemas.
The file's header names the profile "wiithrow", and a metadata record `wiithrow` holds
`format_version` (a reader refuses a file from a newer version) and the `digest` of its entries.

Topics (C cameras, c = 0..C-1):

- `/wiimote/c/reports`: the raw HID input reports of remote c, as the driver decoded them (a batch
  read back to back, or one report), each with the host's receive time: the complete source.
- `/wiimote/c/dots`: camera c's frames (dots in pixels, NaN as null).
- `/rig/start`: when the command started tracking, on the rig's clock (`track --record`): what
  the rows' `t` counts from, so that `replay` prints `track`'s rows exactly.
- `/rig/steps`: what the rig did with them (frames processed, flushes): with the reports, what a
  replay needs to track exactly the same markers.
- `/markers`: the tracked markers, with their ids, in the calibration's frame; `/markers/scene`
  the same as Foxglove's `foxglove.SceneUpdate` (a sphere and its id per marker, 20 Hz), which
  Foxglove's 3D panel draws.
- `/calibration`: the projection matrices in use, at the start and at every change.
- `/tf`: the frames (base, link1, cameras) as `foxglove.FrameTransforms`.
- `/arm/joints`, `/arm/trajectory`, `/throws`: a session's arm and throws; a throw's `record`
  holds its `outcome` (`ThrowRecord.to_dict`), whose `error` and `true_error` are the 3D error
  along / across / height / total (`LANDING_ERROR`: fields added to the schema, the format's
  version unchanged, so that a reader of the earlier files reads these and an earlier reader these).
"""

from __future__ import annotations

import json
import zlib
from typing import Any

from wiithrow.app.errors import AppError

#: This writer's format; a reader refuses files whose version is higher.
FORMAT_VERSION = 1
PROFILE = "wiithrow"
METADATA_NAME = "wiithrow"
CALIBRATION_ATTACHMENT = "calibration.json"


class RecordingError(AppError):
    """A recording that cannot be written or read (one line for the command line)."""


def digest(metadata: dict[str, str]) -> str:
    """A CRC-32 of the metadata's other entries: MCAP keeps no checksum of metadata records."""
    entries = {k: v for k, v in metadata.items() if k != "digest"}
    return f"{zlib.crc32(json.dumps(entries, sort_keys=True).encode()):08x}"


def reports_topic(camera: int) -> str:
    return f"/wiimote/{camera}/reports"


def dots_topic(camera: int) -> str:
    return f"/wiimote/{camera}/dots"


STEPS = "/rig/steps"
TRACKING_START = "/rig/start"
MARKERS = "/markers"
MARKERS_SCENE = "/markers/scene"
CALIBRATION = "/calibration"
TF = "/tf"
JOINTS = "/arm/joints"
TRAJECTORY = "/arm/trajectory"
THROWS = "/throws"

_NUM = {"type": "number"}
_VEC3 = {"type": "object", "properties": {"x": _NUM, "y": _NUM, "z": _NUM}}
_TIME = {"type": "object", "properties": {"sec": {"type": "integer"}, "nsec": {"type": "integer"}}}


def _array(items: dict[str, Any]) -> dict[str, Any]:
    return {"type": "array", "items": items}


def _object(title: str, **properties: Any) -> dict[str, Any]:
    return {"title": title, "type": "object", "properties": properties}


_NUM_OR_NULL = {"type": ["number", "null"]}
#: A throw's error (`wiithrow.throwing.landing_error.LandingError.to_dict`), m; null where unknown.
LANDING_ERROR = _object(
    "wiithrow.LandingError",
    along_m=_NUM_OR_NULL | {"description": "along the throw, + beyond the target (x of link1 turned onto it)"},
    across_m=_NUM_OR_NULL | {"description": "across the throw plane, + toward link1's +y"},
    height_m=_NUM_OR_NULL | {"description": "the landing's height over the target's"},
    total_m=_NUM_OR_NULL | {"description": "the distance on the landing surface: sqrt(along^2 + across^2)"},
)


# name -> JSON Schema, one per schema the file registers.
SCHEMAS: dict[str, dict[str, Any]] = {
    "wiithrow.HidReports": _object(
        "wiithrow.HidReports",
        camera={"type": "integer"},
        t=_array(_NUM) | {"description": "receive time of each report on the rig's clock (s)"},
        data=_array({"type": "string"}) | {"description": "each report's bytes in hex (byte 0: report id)"},
    ),
    "wiithrow.Dots": _object(
        "wiithrow.Dots",
        camera={"type": "integer"},
        t={"description": "arrival time (s)"} | _NUM,
        t_device={"description": "estimated send time (s)"} | _NUM,
        seq={"type": "integer"},
        dots=_array({"type": ["array", "null"], "items": _NUM}),
    ),
    "wiithrow.RigStep": _object(
        "wiithrow.RigStep",
        step={"enum": ["process", "flush"]},
        camera={"type": "integer"},
        frames={"type": "integer", "description": "frames processed, or reference frames flushed"},
        t={"description": "the flush's time (s)"} | _NUM,
    ),
    "wiithrow.TrackingStart": _object(
        "wiithrow.TrackingStart",
        t={"description": "the rig's clock when tracking started (s): the rows' t counts from it"} | _NUM,
    ),
    "wiithrow.Markers": _object(
        "wiithrow.Markers",
        t=_NUM,
        frame_id={"type": "string"},
        ids=_array({"type": "integer"}),
        positions=_array(_array(_NUM)),
        visible=_array({"type": "boolean"}),
        views=_array({"type": "integer"}),
    ),
    "wiithrow.Calibration": _object(
        "wiithrow.Calibration",
        frame_id={"type": "string"},
        Ps=_array(_array(_array(_NUM))) | {"description": "projection matrices (C, 3, 4)"},
    ),
    "wiithrow.JointState": _object("wiithrow.JointState", t=_NUM, q=_array(_NUM), dq=_array(_NUM)),
    "wiithrow.Trajectory": _object(
        "wiithrow.Trajectory", t=_NUM, times=_array(_NUM), q=_array(_array(_NUM)), what={"type": "string"}
    ),
    "wiithrow.Throw": _object(
        "wiithrow.Throw",
        t=_NUM,
        record=_object(
            "wiithrow.ThrowRecord",
            index={"type": "integer"},
            q1=_NUM,
            outcome=_object(
                "wiithrow.ThrowOutcome",
                error=LANDING_ERROR,
                true_error=LANDING_ERROR | {"type": ["object", "null"]},
                error_m=_NUM_OR_NULL | {"description": "the error's total (m)"},
                true_error_m=_NUM_OR_NULL | {"description": "the true error's total (m; simulation only)"},
            ),
        ),
    ),
    "foxglove.SceneUpdate": _object(
        "foxglove.SceneUpdate",
        deletions=_array({"type": "object"}),
        entities=_array(
            _object(
                "foxglove.SceneEntity",
                timestamp=_TIME,
                frame_id={"type": "string"},
                id={"type": "string"},
                lifetime=_TIME,
                frame_locked={"type": "boolean"},
                spheres=_array({"type": "object", "description": "foxglove.SpherePrimitive: pose, size, color"}),
                texts=_array({"type": "object", "description": "foxglove.TextPrimitive: the marker's id"}),
            )
        ),
    ),
    "foxglove.FrameTransforms": _object(
        "foxglove.FrameTransforms",
        transforms=_array(
            _object(
                "foxglove.FrameTransform",
                timestamp=_TIME,
                parent_frame_id={"type": "string"},
                child_frame_id={"type": "string"},
                translation=_VEC3,
                rotation={"type": "object", "properties": {"x": _NUM, "y": _NUM, "z": _NUM, "w": _NUM}},
            )
        ),
    ),
}

TOPIC_SCHEMAS = {
    STEPS: "wiithrow.RigStep",
    TRACKING_START: "wiithrow.TrackingStart",
    MARKERS: "wiithrow.Markers",
    MARKERS_SCENE: "foxglove.SceneUpdate",
    CALIBRATION: "wiithrow.Calibration",
    TF: "foxglove.FrameTransforms",
    JOINTS: "wiithrow.JointState",
    TRAJECTORY: "wiithrow.Trajectory",
    THROWS: "wiithrow.Throw",
}


def schema_of(topic: str) -> str:
    """The schema name of a topic."""
    if topic.endswith("/reports"):
        return "wiithrow.HidReports"
    if topic.endswith("/dots"):
        return "wiithrow.Dots"
    return TOPIC_SCHEMAS[topic]


def schema_bytes(name: str) -> bytes:
    return json.dumps(SCHEMAS[name]).encode()
