"""`RigMessages`: what a rig's events (and a session's arm) write on the channels, for any JSON sink.

A rig tells its listeners what it did (`wiithrow.app.rig.events`: the raw reports its drivers read,
each camera's frames processed with the tracked frames they completed, each flush, each
calibration); `event` turns each into the channels' JSON messages (`json_messages`) in the order
they happen and hands each to `write(topic, stamp_ns, message)`: the recording's MCAP writer
(`mcap_sink`), Foxglove's server (`foxglove_sink`), in this process or in a writer process that
unpacks the rig's records into the same calls. A processed camera frame writes its dots, the rig's
step (what a replay repeats) and the markers it tracked; `/markers/scene` is written at most every
`SCENE_PERIOD_S` of the rig's clock; a calibration writes `/calibration` and the cameras' frames
on `/tf_static`; a session's arm sample (`arm`) writes `/arm/joints` and base -> link1 on `/tf`.

Stamps are the rig's clock in Unix time (`wall_time`); `wanted(topic)` says whether to build a
topic's message at all (Foxglove: a channel nobody subscribed to is not built).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from wiithrow.app.channels import json_messages as jm
from wiithrow.app.channels import registry as r
from wiithrow.app.channels.wall_time import WallTime
from wiithrow.app.rig.events import CalibrationChanged, Flushed, FramesProcessed, ReportsRead, RigEvent
from wiithrow.vision.tracked_frame import TrackedFrame
from wiithrow.vision.wiimote.frames import IRFrame

SCENE_PERIOD_S = 0.05  # /markers/scene: Foxglove's 3D view of the markers, at 20 Hz

Write = Callable[[str, int, dict[str, Any]], object]


def _always(topic: str) -> bool:
    return True


class RigMessages:
    """A rig's events as the channels' messages, each to `write` (module docstring)."""

    def __init__(self, write: Write, wall: WallTime, frame_id: str, *, wanted: Callable[[str], bool] = _always) -> None:
        self.write = write
        self.wall = wall
        self.frame_id = frame_id
        self.wanted = wanted
        self._last_scene = -1e9

    def event(self, event: RigEvent, now: float = 0.0) -> None:
        """One event of the rig (`now`: the rig's clock, for a calibration)."""
        if isinstance(event, ReportsRead):
            self.reports(event.camera, event.batch)
        elif isinstance(event, FramesProcessed):
            self.processed(event.camera, event.frames, event.tracked)
        elif isinstance(event, Flushed):
            self.flushed(event.now, event.synced, event.tracked)
        elif isinstance(event, CalibrationChanged):
            self.calibrated(event.Ps, now)

    def reports(self, camera: int, batch: Sequence[tuple[float, bytes]]) -> None:
        topic = r.REPORTS.topic_of(camera)
        if batch and self.wanted(topic):
            self.write(topic, self.wall.stamp_ns(batch[-1][0]), jm.reports_message(camera, batch))

    def processed(self, camera: int, frames: Sequence[IRFrame], tracked: Sequence[TrackedFrame]) -> None:
        if not frames:
            return
        topic = r.DOTS.topic_of(camera)
        if self.wanted(topic):
            for f in frames:
                self.write(topic, self.wall.stamp_ns(f.t), jm.dots_message(camera, f))
        if self.wanted(r.STEPS.topic):
            self.write(r.STEPS.topic, self.wall.stamp_ns(frames[-1].t), jm.processed_step(camera, len(frames)))
        self.markers(tracked)

    def flushed(self, now: float, synced: int, tracked: Sequence[TrackedFrame]) -> None:
        if not synced:
            return
        if self.wanted(r.STEPS.topic):
            self.write(r.STEPS.topic, self.wall.stamp_ns(now), jm.flushed_step(now, synced))
        self.markers(tracked)

    def markers(self, tracked: Sequence[TrackedFrame]) -> None:
        if tracked and tracked[-1].t - self._last_scene >= SCENE_PERIOD_S and self.wanted(r.SCENE.topic):
            self._last_scene = tracked[-1].t
            stamp_ns = self.wall.stamp_ns(tracked[-1].t)
            self.write(r.SCENE.topic, stamp_ns, jm.scene_message(tracked[-1], self.frame_id, stamp_ns))
        if self.wanted(r.MARKERS.topic):
            for f in tracked:
                self.write(r.MARKERS.topic, self.wall.stamp_ns(f.t), jm.markers_message(f, self.frame_id))

    def calibrated(self, Ps: NDArray[np.float64], t: float) -> None:
        """A calibration at `t` (the rig's clock): `/calibration`, and the cameras on `/tf_static`."""
        stamp_ns = self.wall.stamp_ns(t)
        self.write(r.CALIBRATION.topic, stamp_ns, jm.calibration_message(Ps, self.frame_id))
        transforms = jm.camera_transforms(np.asarray(Ps, dtype=float), self.frame_id, stamp_ns)
        self.write(r.TF_STATIC.topic, stamp_ns, jm.transforms_message(transforms))

    def mark_start(self, t: float) -> None:
        """The command started tracking at `t`: `/rig/start`, what a replay's rows count t from."""
        self.write(r.TRACKING_START.topic, self.wall.stamp_ns(t), jm.start_message(t))

    def arm(self, t: float, names: Sequence[str], q: ArrayLike, dq: ArrayLike, T: NDArray[np.float64]) -> None:
        """A session's arm at `t`: its joints, and base -> link1 (`T`, 4x4)."""
        stamp_ns = self.wall.stamp_ns(t)
        if self.wanted(r.JOINTS.topic):
            self.write(r.JOINTS.topic, stamp_ns, jm.joints_message(t, names, q, dq))
        if self.wanted(r.TF.topic):
            transform = jm.frame_transform(np.asarray(T, dtype=float), "base", "link1", stamp_ns)
            self.write(r.TF.topic, stamp_ns, jm.transforms_message([transform]))
