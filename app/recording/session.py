"""`SessionRecorder`: a session's run to MCAP: its rig (as `Recorder`), and its arm and throws.

On top of what `Recorder` writes of the rig, it samples the arm's measured joints (`/arm/joints`,
at most 50 Hz of the world's clock, read while the rig reports its frames) with the frames base
-> link1 and link1 -> cameras (`/tf`, Foxglove's `FrameTransforms`: base at the root), and
listens to the session's events: each previewed throw's commanded trajectory (`/arm/trajectory`)
and each throw's plan, release, landing and error (`/throws`). A new calibration is attached to
the file too (`calibration.json` at the start; `/calibration` at every change).
"""

from __future__ import annotations

import json
import os
from collections.abc import Callable, Sequence

from wiithrow.app.recording.channels import RecordingError
from wiithrow.app.recording.recorder import Recorder, _stderr, camera_transforms, frame_transform
from wiithrow.app.rig.stream import RigStream
from wiithrow.app.session import Event, Session
from wiithrow.vision.files import dumps_strict
from wiithrow.vision.tracked_frame import TrackedFrame
from wiithrow.vision.wiimote.frames import IRFrame

JOINTS_PERIOD_S = 0.02


class SessionRecorder(Recorder):
    """Records `session` to `path` from `start()` to `close()` (see the module docstring)."""

    def __init__(
        self, session: Session, path: str | os.PathLike[str], *, on_error: Callable[[str], object] = _stderr
    ) -> None:
        world = session.world
        calibration = world.calibration
        super().__init__(
            path,
            world.clock,
            frame_id="link1",
            calibration_text=calibration.to_text() if calibration is not None else None,
            on_error=on_error,
            extra_metadata={"arm": world.arm_model.name},
        )
        self.session = session
        self._last_joints = -1e9
        self._throws_seen = 0

    def begin(self) -> None:
        """Start recording the session's rig, arm and throws (RecordingError for a rig whose
        markers another host tracks: no report is read here)."""
        rig = self.session.world.rig
        if not isinstance(rig, RigStream):
            raise RecordingError("no remote is read here (the markers come from another host): record where they are")
        self.start(rig)
        self._throws_seen = len(self.session.history)
        self.session.subscribe(self._event)

    def close(self) -> None:
        self.session.unsubscribe(self._event)
        super().close()

    def processed(self, camera: int, frames: Sequence[IRFrame], tracked: Sequence[TrackedFrame]) -> None:
        super().processed(camera, frames, tracked)
        if frames and frames[-1].t - self._last_joints >= JOINTS_PERIOD_S:
            self._last_joints = frames[-1].t
            self._sample_arm(frames[-1].t)

    def _sample_arm(self, t: float) -> None:
        world = self.session.world
        try:
            state = world.arm.state()
            T = world.arm_model.frame_placement(state.q, "link1")
        except Exception:  # an arm that cannot say where it is now: no sample this time
            return
        self.record_joints(t, state.q, state.dq)
        Ps = world.rig.Ps
        transforms = [frame_transform(T, "base", "link1", t)]
        if Ps is not None:
            transforms += camera_transforms(Ps, "link1", t)
        self.record_transforms(t, transforms)

    def _event(self, event: Event) -> None:
        t = self.clock.now()
        if event is Event.PREVIEW and self.session.preview is not None:
            trajectory = self.session.preview.throw.trajectory
            self.record_trajectory(
                t, trajectory.times, trajectory.positions, f"throw preview {self.session.preview.id}"
            )
        elif event is Event.THROW:
            history = self.session.history
            # a new throw, or the last one's landing measured since (Measure landing)
            for record in history[min(self._throws_seen, len(history) - 1) :] if history else []:
                ex = record.execution
                document = {
                    "index": record.index,
                    "q1": record.q1,
                    "outcome": record.to_dict(),
                    "release": {
                        "t": ex.t_release,
                        "q": ex.release.q,
                        "dq": ex.release.dq,
                        "position_base_m": ex.release.position,
                        "velocity_base_m_s": ex.release.velocity,
                    },
                }
                self.record_throw(t, json.loads(dumps_strict(document)))
            self._throws_seen = len(history)
