"""Recording a run to one MCAP file and replaying it through the same pipeline.

Modules: `channels` (the file's format version, topics and JSON schemas, Foxglove's among them),
`recorder` (`Recorder`: a rig's raw reports, dots, markers, calibration and frames, written as
they happen), `session` (`SessionRecorder`: a session's arm and throws too), `reading` (a
recording's leading records, then its messages streamed a chunk at a time, as far as the file is
intact, within stated limits), `replay` (`Replay`, a marker source that feeds the raw reports
through the `ReportDecoder`, the synchroniser and the tracker again, as it reads them),
`replayed_remote` (a recording's remotes as transports, for the dashboard).

The names below are imported when first used (`wiithrow.lazy_exports`): a Foxglove writer
process, which needs `recorder` and `channels`, does not import the reading's alignment nor the
replay's tracker.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from wiithrow.lazy_exports import lazy_exports

if TYPE_CHECKING:
    from wiithrow.app.recording.channels import FORMAT_VERSION, RecordingError
    from wiithrow.app.recording.reading import MAX_CHUNK_BYTES, Recording, read_recording
    from wiithrow.app.recording.recorder import Recorder
    from wiithrow.app.recording.replay import Replay, replay_markers

#: Each public name and the module that defines it.
_HOMES = {
    "FORMAT_VERSION": "channels",
    "RecordingError": "channels",
    "MAX_CHUNK_BYTES": "reading",
    "Recording": "reading",
    "read_recording": "reading",
    "Recorder": "recorder",
    "Replay": "replay",
    "replay_markers": "replay",
}

__all__ = [
    "FORMAT_VERSION",
    "MAX_CHUNK_BYTES",
    "Recorder",
    "Recording",
    "RecordingError",
    "Replay",
    "read_recording",
    "replay_markers",
]

__getattr__, __dir__ = lazy_exports(__name__, _HOMES)
