"""The Foxglove writer process: `python -m wiithrow.app.channels.foxglove_writer CONFIG` (`FoxgloveProcessLive`).

Serves foxglove-sdk's WebSocket server (`FoxgloveServer`: `CONFIG`'s host and port, the rig's
channels advertised, and a session's with `session`) fed with the ring's records through
`RigMessages`, as a recording is: each event's records, up to its `END`, become the call the rig's
event would have made in-process (`reports`, `processed`, `flushed`), a `CALIBRATION` record
`calibrated`, an `ARM` record `arm` (`/arm/joints`, `/tf`): the same channels, schemas and
messages. A session's message (`{"write": [topic, stamp_ns, message]}` on stdin, built by
`SessionFeed`'s code) is written as it is. Its figures (the port, what it wants handed over: all
while a client is subscribed to anything, else nothing; the messages logged) go to the ring's
header. Ends when stdin closes (`writer_process.run`), stopping the server.
"""

from __future__ import annotations

import json
import sys
from typing import Any

from wiithrow.app.channels import records
from wiithrow.app.channels import registry as r
from wiithrow.app.channels.foxglove_sink import LOGGED, PORT, FoxgloveServer
from wiithrow.app.channels.frame_ring import FrameRing
from wiithrow.app.channels.rig_messages import RigMessages
from wiithrow.app.channels.sink_process import WANT_ALL, WANTS
from wiithrow.app.channels.wall_time import WallTime
from wiithrow.app.channels.writer_process import run
from wiithrow.vision.tracked_frame import TrackedFrame
from wiithrow.vision.wiimote.frames import IRFrame


class FoxgloveWriter:
    """The child's sink: the server and the rig's messages (module docstring)."""

    def __init__(self, config: dict[str, Any], ring: FrameRing) -> None:
        self.ring = ring
        self.server = FoxgloveServer(
            int(config["port"]), str(config["host"]), True
        )  # the host was checked by the parent
        cameras = len(config["cameras"])
        self.server.advertise(r.topics(r.RIG_CHANNELS, cameras))
        if config.get("session"):
            self.server.advertise(r.topics(r.SESSION_CHANNELS, cameras))
        self.joint_names = list(config.get("joint_names", []))
        self.messages = RigMessages(
            self.server.write, WallTime(int(config["offset_ns"])), str(config["frame_id"]), wanted=self.server.wanted
        )
        self.dots: list[IRFrame] = []
        self.tracked: list[TrackedFrame] = []
        self.reports: list[tuple[float, bytes]] = []
        ring.report(PORT, self.server.port)

    def on_records(self, batch: list[bytes]) -> None:
        for data in batch:
            record = records.unpack(data)
            if isinstance(record, records.Dots):
                self.dots.append(record.frame)
            elif isinstance(record, records.Markers):
                self.tracked.append(record.frame)
            elif isinstance(record, records.Report):
                self.reports.append((record.t, record.data))
            elif isinstance(record, records.Calibration):
                self.messages.calibrated(record.Ps, record.t)
            elif isinstance(record, records.End):
                self.end(record)
            elif isinstance(record, records.Arm):
                self.messages.arm(record.t, self.joint_names, record.q, record.dq, record.T)

    def end(self, record: records.End) -> None:
        if record.event == records.PROCESSED:
            self.messages.processed(record.camera, self.dots, self.tracked)
        elif record.event == records.FLUSHED:
            self.messages.flushed(record.now, record.synced, self.tracked)
        elif record.event == records.REPORTS:
            self.messages.reports(record.camera, self.reports)
        self.dots, self.tracked, self.reports = [], [], []

    def on_message(self, message: dict[str, Any]) -> None:
        if "write" in message:
            topic, stamp_ns, body = message["write"]
            self.server.write(str(topic), int(stamp_ns), body)

    def on_idle(self) -> None:
        self.ring.report(WANTS, WANT_ALL if self.server.watched() else 0)
        self.ring.report(LOGGED, self.server.logged)

    def close(self) -> None:
        self.on_idle()
        self.server.stop()


if __name__ == "__main__":
    sys.exit(run("Foxglove", json.loads(sys.argv[1]), FoxgloveWriter))
