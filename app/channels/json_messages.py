"""The channels' JSON messages, built once for every sink (a recording, Foxglove live, and the ROS 2
forms that `ros2_messages` encodes from them).

One function per channel (`registry`), each returning the dict its JSON Schema describes
(`json_schemas`); `encode` turns it into the bytes a file or a server carries (msgspec's encoder:
shortest round-trip floats as `json`'s, a tenth of `json.dumps`' cost, which matters at 7 messages
per frame). Times: `t` on the rig's clock (s); stamps (`timestamp`) Unix time (`wall_time`).
"""

from __future__ import annotations

import functools
from collections.abc import Sequence
from typing import Any

import msgspec
import numpy as np
from numpy.typing import ArrayLike, NDArray

from wiithrow.app.channels.wall_time import stamp
from wiithrow.vision.geometry import decompose, quaternion_xyzw
from wiithrow.vision.tracked_frame import TrackedFrame
from wiithrow.vision.wiimote.frames import IRFrame

encode = msgspec.json.Encoder().encode

#: The markers' 3D view: a sphere of 3 cm (its id 4 cm above it), orange when seen, grey while predicted.
MARKER_SIZE_M = 0.03
LABEL_ABOVE_M = 0.04
SEEN = {"r": 1.0, "g": 0.3, "b": 0.1, "a": 1.0}
PREDICTED = {"r": 0.6, "g": 0.6, "b": 0.6, "a": 0.6}
_IDENTITY = {"x": 0.0, "y": 0.0, "z": 0.0, "w": 1.0}
_EMPTY = ("arrows", "cubes", "cylinders", "lines", "triangles", "models", "metadata")


def reports_message(camera: int, batch: Sequence[tuple[float, bytes]]) -> dict[str, Any]:
    return {"camera": camera, "t": [t for t, _ in batch], "data": [d.hex() for _, d in batch]}


def dots_message(camera: int, frame: IRFrame) -> dict[str, Any]:
    dots = [None if u != u or v != v else [u, v] for u, v in frame.dots.tolist()]
    return {"camera": camera, "t": frame.t, "t_device": frame.t_device, "seq": frame.seq, "dots": dots}


def processed_step(camera: int, frames: int) -> dict[str, Any]:
    return {"step": "process", "camera": camera, "frames": frames}


def flushed_step(now: float, synced: int) -> dict[str, Any]:
    return {"step": "flush", "camera": -1, "frames": synced, "t": now}


def start_message(t: float) -> dict[str, Any]:
    return {"t": t}


def markers_message(frame: TrackedFrame, frame_id: str) -> dict[str, Any]:
    return {
        "t": frame.t,
        "frame_id": frame_id,
        "ids": frame.ids.tolist(),
        "positions": frame.position.tolist(),
        "visible": frame.visible.tolist(),
        "views": frame.n_views.tolist(),
    }


def scene_message(frame: TrackedFrame, frame_id: str, stamp_ns: int) -> dict[str, Any]:
    """The markers as a Foxglove SceneUpdate: a sphere per marker and its id above it, replaced by the next update."""
    spheres, texts = [], []
    for i, (x, y, z), seen in zip(frame.ids.tolist(), frame.position.tolist(), frame.visible.tolist()):
        color = SEEN if seen else PREDICTED
        spheres.append(
            {
                "pose": {"position": {"x": x, "y": y, "z": z}, "orientation": _IDENTITY},
                "size": {"x": MARKER_SIZE_M, "y": MARKER_SIZE_M, "z": MARKER_SIZE_M},
                "color": color,
            }
        )
        texts.append(
            {
                "pose": {"position": {"x": x, "y": y, "z": z + LABEL_ABOVE_M}, "orientation": _IDENTITY},
                "billboard": True,
                "font_size": 14.0,
                "scale_invariant": True,
                "color": color,
                "text": str(i),
            }
        )
    entity = {
        "timestamp": stamp(stamp_ns),
        "frame_id": frame_id,
        "id": "markers",
        "lifetime": {"sec": 0, "nsec": 0},
        "frame_locked": False,
        "spheres": spheres,
        "texts": texts,
        **{k: [] for k in _EMPTY},
    }
    return {"deletions": [], "entities": [entity]}


def calibration_message(Ps: ArrayLike, frame_id: str) -> dict[str, Any]:
    return {"frame_id": frame_id, "Ps": np.asarray(Ps, dtype=float).tolist()}


def frame_transform(T: NDArray[np.float64], parent: str, child: str, stamp_ns: int) -> dict[str, Any]:
    """A `foxglove.FrameTransform`: the 4x4 pose `T` of `child` in `parent`, stamped `stamp_ns` (Unix ns)."""
    x, y, z, w = quaternion_xyzw(T[:3, :3])
    return {
        "timestamp": stamp(stamp_ns),
        "parent_frame_id": parent,
        "child_frame_id": child,
        "translation": dict(zip("xyz", T[:3, 3].tolist())),
        "rotation": {"x": x, "y": y, "z": z, "w": w},
    }


def camera_frame(camera: int) -> str:
    """The frame of camera c (x right, y down, z forward: ROS' optical frames)."""
    return f"camera_{camera}"


def camera_transforms(Ps: NDArray[np.float64], frame_id: str, stamp_ns: int) -> list[dict[str, Any]]:
    """Each camera's pose in `frame_id` as FrameTransforms (child `camera_c`)."""
    Ps = np.ascontiguousarray(Ps, dtype=np.float64)
    when = stamp(stamp_ns)
    return [
        {
            "timestamp": when,
            "parent_frame_id": frame_id,
            "child_frame_id": camera_frame(c),
            "translation": dict(translation),
            "rotation": dict(rotation),
        }
        for c, (translation, rotation) in enumerate(_camera_poses(Ps.tobytes(), Ps.shape[0]))
    ]


@functools.lru_cache(maxsize=8)
def _camera_poses(Ps_bytes: bytes, count: int) -> tuple[tuple[tuple[tuple[str, float], ...], ...], ...]:
    """Each camera's (translation, rotation) items: its centre and the quaternion of R^T (camera ->
    frame), computed once per calibration (a decomposition costs about 0.2 ms a camera)."""
    out = []
    for P in np.frombuffer(Ps_bytes, dtype=np.float64).reshape(count, 3, 4):
        d = decompose(P)
        x, y, z, w = quaternion_xyzw(d.R.T)
        cx, cy, cz = d.center.tolist()
        out.append(((("x", cx), ("y", cy), ("z", cz)), (("x", x), ("y", y), ("z", z), ("w", w))))
    return tuple(out)


def transforms_message(transforms: list[dict[str, Any]]) -> dict[str, Any]:
    return {"transforms": transforms}


def joints_message(t: float, names: Sequence[str], q: ArrayLike, dq: ArrayLike) -> dict[str, Any]:
    return {"t": t, "names": list(names), "q": np.asarray(q, float).tolist(), "dq": np.asarray(dq, float).tolist()}


def trajectory_message(t: float, names: Sequence[str], times: ArrayLike, q: ArrayLike, what: str) -> dict[str, Any]:
    return {
        "t": t,
        "names": list(names),
        "times": np.asarray(times, float).tolist(),
        "q": np.asarray(q, float).tolist(),
        "what": what,
    }


def throw_message(t: float, record: dict[str, Any]) -> dict[str, Any]:
    """A throw: `record` is its document (`wiithrow.app.recording.session.throw_document`)."""
    return {"t": t, "record": record}


def robot_description_message(urdf: str) -> dict[str, Any]:
    return {"data": urdf}
