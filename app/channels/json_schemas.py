"""The JSON Schemas of the channels' JSON messages (a recording's and Foxglove's), by schema name.

Every JSON message a recording or Foxglove live carries is one object with the schema its channel
names (`registry`): wiithrow's own (`wiithrow.*`), Foxglove's well-known `foxglove.SceneUpdate` and
`foxglove.FrameTransforms` (Foxglove draws them in 3D), and `std_msgs/msg/String` (the robot
description, under ROS 2's name: what Foxglove's URDF layer reads from a topic). Stamps are
`{sec, nsec}` of Unix time; `t` fields are on the rig's clock (s): what a replay feeds the
pipeline again (`wall_time`: how the two relate).
"""

from __future__ import annotations

import json
from typing import Any

_NUM = {"type": "number"}
_VEC3 = {"type": "object", "properties": {"x": _NUM, "y": _NUM, "z": _NUM}}
_TIME = {"type": "object", "properties": {"sec": {"type": "integer"}, "nsec": {"type": "integer"}}}
_NAMES = {"type": "array", "items": {"type": "string"}, "description": "the joints' names, in the order of q"}


def _array(items: dict[str, Any]) -> dict[str, Any]:
    return {"type": "array", "items": items}


def _object(title: str, **properties: Any) -> dict[str, Any]:
    return {"title": title, "type": "object", "properties": properties}


_FRAME_TRANSFORMS = _object(
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
)

_NUM_OR_NULL = {"type": ["number", "null"]}
#: A throw's error (`wiithrow.throwing.landing_error.LandingError.to_dict`), m; null where unknown.
LANDING_ERROR = _object(
    "wiithrow.LandingError",
    along_m=_NUM_OR_NULL | {"description": "along the throw, + beyond the target (x of link1 turned onto it)"},
    across_m=_NUM_OR_NULL | {"description": "across the throw plane, + toward link1's +y"},
    height_m=_NUM_OR_NULL | {"description": "the landing's height over the target's"},
    total_m=_NUM_OR_NULL | {"description": "the distance on the landing surface: sqrt(along^2 + across^2)"},
)

# name -> JSON Schema, one per schema a channel names.
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
    "wiithrow.JointState": _object("wiithrow.JointState", t=_NUM, names=_NAMES, q=_array(_NUM), dq=_array(_NUM)),
    "wiithrow.Trajectory": _object(
        "wiithrow.Trajectory",
        t=_NUM,
        names=_NAMES,
        times=_array(_NUM),
        q=_array(_array(_NUM)),
        what={"type": "string"},
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
    "std_msgs/msg/String": _object("std_msgs/msg/String", data={"type": "string", "description": "the arm's URDF"}),
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
    "foxglove.FrameTransforms": _FRAME_TRANSFORMS,
}


def schema_bytes(name: str) -> bytes:
    """The JSON Schema `name` as the bytes a file or a server registers."""
    return json.dumps(SCHEMAS[name]).encode()
