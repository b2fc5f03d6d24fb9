"""The Foxglove writer process: `python -m wiithrow.app.foxglove.writer_main CONFIG` (`FoxgloveProcessLive`).

Serves foxglove-sdk's WebSocket server (`live.FoxgloveServer`: `CONFIG`'s host and port, the
rig's channels advertised) and a `Recorder` whose writes go to it, fed with the ring's records:
each event's records, up to its `END`, become the `Recorder` call the rig's event would have
made in-process (`reports`, `processed`, `flushed`, `calibrated`): the same channels, schemas
and messages. For a session (`CONFIG`'s `session`: `FoxgloveSessionProcessLive`) the session's
channels are advertised too, an `ARM` record becomes `/arm/joints` and `/tf` as
`SessionRecorder._sample_arm` writes them (the cameras from the last calibration record), and a
`{"write": [topic, t, message]}` line on stdin (a message the recorder's own code built) is
written as it is. Its figures (the port, whether a client is subscribed, the messages logged) go to
the ring's header. Ends when stdin closes (`writer_process.serve`), stopping the server.
"""

from __future__ import annotations

import json
import sys
from typing import Any

from wiithrow.app.errors import AppError
from wiithrow.app.foxglove.process_live import LOGGED, PORT, WATCHED
from wiithrow.app.foxglove.server import SESSION_TOPICS, FoxgloveServer, rig_topics
from wiithrow.app.network import frame_records as records
from wiithrow.app.network.writer_process import open_ring, serve
from wiithrow.app.recording.recorder import Recorder, camera_transforms, frame_transform
from wiithrow.vision.tracked_frame import TrackedFrame
from wiithrow.vision.wiimote.frames import IRFrame


class _Now:
    """The rig's time as the records tell it (a `Clock` for the `Recorder`'s calibration stamps)."""

    def __init__(self) -> None:
        self.t = 0.0

    def now(self) -> float:
        return self.t


class _LiveRecorder(Recorder):
    def __init__(self, server: FoxgloveServer, clock: _Now, frame_id: str) -> None:
        super().__init__("unused.mcap", clock, frame_id=frame_id)  # type: ignore[arg-type]  # only now() is read
        self.server = server

    def _write(self, topic: str, t: float, message: dict[str, Any]) -> None:
        self.server.write(topic, t, message)


def main(config: dict[str, Any]) -> int:
    ring = open_ring(config)
    try:
        server = FoxgloveServer(int(config["port"]), str(config["host"]), True)  # the host was checked by the parent
    except AppError as exc:
        print(str(exc), file=sys.stderr, flush=True)
        return 1
    server.advertise(rig_topics(int(config["cameras"])))
    if config.get("session"):
        server.advertise(SESSION_TOPICS)
    clock = _Now()
    recorder = _LiveRecorder(server, clock, str(config["frame_id"]))
    dots: list[IRFrame] = []
    tracked: list[TrackedFrame] = []
    reports: list[tuple[float, bytes]] = []
    Ps: list[Any] = []

    def on_records(batch: list[bytes]) -> None:
        for data in batch:
            record = records.unpack(data)
            if isinstance(record, records.Dots):
                dots.append(record.frame)
            elif isinstance(record, records.Markers):
                tracked.append(record.frame)
            elif isinstance(record, records.Report):
                reports.append((record.t, record.data))
            elif isinstance(record, records.Calibration):
                Ps[:] = [record.Ps]
            elif isinstance(record, records.End):
                end(record)
            elif isinstance(record, records.Arm):
                arm(record)

    def arm(record: records.Arm) -> None:
        """`SessionRecorder._sample_arm`'s messages of one sample."""
        recorder.record_joints(record.t, record.q, record.dq)
        transforms = [frame_transform(record.T, "base", "link1", record.t)]
        if Ps:
            transforms += camera_transforms(Ps[0], "link1", record.t)
        recorder.record_transforms(record.t, transforms)

    def end(record: records.End) -> None:
        if record.event == records.PROCESSED:
            recorder.processed(record.camera, list(dots), list(tracked))
        elif record.event == records.FLUSHED:
            clock.t = record.now
            recorder.flushed(record.now, record.synced, list(tracked))
        elif record.event == records.REPORTS and reports:
            recorder.reports(record.camera, list(reports))
        elif record.event == records.CALIBRATED and Ps:
            clock.t = record.now
            recorder.calibrated(Ps[0])
        dots.clear()
        tracked.clear()
        reports.clear()

    def on_message(message: dict[str, Any]) -> None:
        if "write" in message:
            topic, t, body = message["write"]
            server.write(str(topic), float(t), body)

    def on_idle() -> None:
        ring.report(WATCHED, int(server.watched()))
        ring.report(LOGGED, server.logged)

    ring.report(PORT, server.port)
    try:
        return serve("Foxglove", ring, on_records, on_message, on_idle)
    finally:
        on_idle()
        server.stop()
        ring.close()


if __name__ == "__main__":
    sys.exit(main(json.loads(sys.argv[1])))
