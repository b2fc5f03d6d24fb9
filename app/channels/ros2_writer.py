"""The ROS 2 writer process: `python -m wiithrow.app.channels.ros2_writer CONFIG` (`Ros2ProcessPublisher`).

Opens the DDS domain as a ROS 2 node (`CONFIG`: JSON, the domain id, the Cyclone configuration,
the node, the cameras, the frame, the namespace, the time offset, a session's joint names; and the
`FrameRing` to read) and a `Ros2Publisher`, and writes each record as its channels' ROS 2 forms: a `MARKERS` record as Markers and MarkerArray
with the tracking process's number, a `DOTS` record as its camera's PointCloud, a `CALIBRATION` as
`/tf_static`, an `ARM` sample as `/tf` and `joint_states` (`RigMessages`: the JSON messages every
sink builds, encoded by `ros2_messages`); a session's message (`{"write": [topic, stamp_ns,
message]}` on stdin) as its channel's forms. Its figures (matched readers of markers, what it
wants handed over, samples written or left unread) go to the ring's header. Ends when stdin closes
(`writer_process.run`), after draining its writers.
"""

from __future__ import annotations

import json
import sys
from typing import Any

from wiithrow.app.channels import json_messages as jm
from wiithrow.app.channels import records
from wiithrow.app.channels import registry as r
from wiithrow.app.channels.frame_ring import FrameRing
from wiithrow.app.channels.rig_messages import RigMessages
from wiithrow.app.channels.ros2_sink import SAMPLES_UNREAD, SAMPLES_WRITTEN, SUBSCRIBERS, Ros2Publisher
from wiithrow.app.channels.sink_process import WANTS
from wiithrow.app.channels.wall_time import WallTime
from wiithrow.app.channels.writer_process import run
from wiithrow.app.ros2.domain import Ros2Domain
from wiithrow.app.ros2.participant import Ros2Node


class Ros2Writer:
    """The child's sink: the domain, its `Ros2Publisher`, the records written (module docstring)."""

    def __init__(self, config: dict[str, Any], ring: FrameRing) -> None:
        self.ring = ring
        self.domain = Ros2Domain(int(config["domain_id"]), str(config["config"]), node=Ros2Node(**config["node"]))
        self.publisher = Ros2Publisher(self.domain, config["cameras"], namespace=config["namespace"])
        self.wall = WallTime(int(config["offset_ns"]))
        self.frame_id = str(config["frame_name"])
        self.joint_names: list[str] = list(config.get("joint_names", []))
        self.messages = RigMessages(self.write, self.wall, self.frame_id, wanted=self.publisher.wanted)

    def write(self, topic: str, stamp_ns: int, message: dict[str, Any]) -> None:
        self.publisher.write(topic, stamp_ns, message)

    def on_records(self, batch: list[bytes]) -> None:
        publisher, wall = self.publisher, self.wall
        for data in batch:
            record = records.unpack(data)
            if isinstance(record, records.Markers):
                message = jm.markers_message(record.frame, self.frame_id)
                publisher.write(r.MARKERS.topic, wall.stamp_ns(record.frame.t), message, record.seq)
            elif isinstance(record, records.Dots):
                topic = r.DOTS.topic_of(record.camera)
                publisher.write(topic, wall.stamp_ns(record.frame.t), jm.dots_message(record.camera, record.frame))
            elif isinstance(record, records.Calibration):
                self.messages.calibrated(record.Ps, record.t)
            elif isinstance(record, records.Arm):
                self.messages.arm(record.t, self.joint_names, record.q, record.dq, record.T)
        if batch:
            self.ring.report(SAMPLES_WRITTEN, publisher.samples_written)

    def on_message(self, message: dict[str, Any]) -> None:
        if "write" in message:
            topic, stamp_ns, body = message["write"]
            self.publisher.write(str(topic), int(stamp_ns), body)

    def on_idle(self) -> None:
        self.ring.report(WANTS, self.publisher.wants())  # before the markers' readers: who waits for those sees this
        self.ring.report(SUBSCRIBERS, self.publisher.subscribers())
        self.ring.report(SAMPLES_WRITTEN, self.publisher.samples_written)
        self.ring.report(SAMPLES_UNREAD, self.publisher.samples_unread)

    def close(self) -> None:
        self.publisher.drain()
        self.on_idle()
        self.domain.close()


if __name__ == "__main__":
    sys.exit(run("ROS 2", json.loads(sys.argv[1]), Ros2Writer))
