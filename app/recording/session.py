"""`SessionRecorder`: a session's run to MCAP: its rig (as `Recorder`), and its arm and throws.

On top of what `Recorder` writes of the rig, it samples the arm (`/arm/joints` and base -> link1 on
`/tf`, at most 50 Hz of the world's clock, read while the rig reports its frames:
`wiithrow.app.channels.sink_process.ArmSampler`) and writes what the session tells
(`session_feed.SessionFeed`: the arm's URDF, each previewed throw's trajectory, each throw). The
calibration is attached to the file too (`calibration.json` at the start; `/calibration` and the
cameras on `/tf_static` at every change).
"""

from __future__ import annotations

import os
from collections.abc import Callable

from wiithrow.app.channels.sink_process import ArmSampler
from wiithrow.app.recording.channels import RecordingError
from wiithrow.app.recording.recorder import Recorder, _stderr
from wiithrow.app.recording.session_feed import SessionFeed
from wiithrow.app.rig.events import FramesProcessed, RigEvent
from wiithrow.app.rig.stream import RigStream
from wiithrow.app.session import Session


class SessionRecorder(Recorder):
    """Records `session` to `path` from `begin()` to `close()` (see the module docstring)."""

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
        self.feed = SessionFeed(session, self._write, self.wall)
        self.arm = ArmSampler(self.feed.arm_state)

    def begin(self) -> None:
        """Start recording the session's rig, arm and throws (RecordingError for a rig whose
        markers another host tracks: no report is read here)."""
        rig = self.session.world.rig
        if not isinstance(rig, RigStream):
            raise RecordingError("no remote is read here (the markers come from another host): record where they are")
        self.start(rig)
        self.feed.start()

    def close(self) -> None:
        self.feed.stop()
        super().close()

    def _event_of_rig(self, event: RigEvent) -> None:
        super()._event_of_rig(event)
        if isinstance(event, FramesProcessed) and event.frames:
            t = event.frames[-1].t
            sample = self.arm.sample(t)
            if sample is not None:
                self.rig_messages.arm(t, self.feed.joint_names, *sample)
