"""Recording a run to one MCAP file and replaying it through the same pipeline.

Modules: `channels` (the file's format version, topics and JSON schemas, Foxglove's among them),
`recorder` (`Recorder`: a rig's raw reports, dots, markers, calibration and frames, written as
they happen), `session` (`SessionRecorder`: a session's arm and throws too), `replay` (reading a recording back, intact
part first; `Replay`, a marker source that feeds its raw reports through the `ReportDecoder`, the
synchroniser and the tracker again).
"""

from wiithrow.app.recording.channels import FORMAT_VERSION, RecordingError
from wiithrow.app.recording.recorder import Recorder
from wiithrow.app.recording.replay import Replay, read_recording, replay_markers

__all__ = ["FORMAT_VERSION", "Recorder", "RecordingError", "Replay", "read_recording", "replay_markers"]
