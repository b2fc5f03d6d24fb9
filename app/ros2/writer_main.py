"""The ROS 2 writer process: `python -m wiithrow.app.ros2.writer_main CONFIG` (`Ros2ProcessPublisher`).

Opens the DDS domain (`CONFIG`: JSON, the domain id, the Cyclone configuration, the ROS 2 node,
the cameras, the frame and the namespace; and the `FrameRing` to read), a `Ros2Publisher` on the caller's
thread, and writes each record of the ring as the in-process publisher would: a `Markers` record
as Markers and MarkerArray with the tracking process's number and stamp, a `Dots` record as the
camera's PointCloud, a `Pose` as `/tf` base -> link1, a `Calibration` as `/tf_static`; a
`{"throw": JSON}` line on stdin as `throws`. Its figures (matched readers of markers, the
cameras whose dots have a reader, samples written or left unread) go to the ring's header. Ends when stdin closes (`writer_process.serve`),
after draining its writers.
"""

from __future__ import annotations

import json
import sys
from typing import Any

from wiithrow.app.errors import AppError
from wiithrow.app.network import frame_records as records
from wiithrow.app.network.writer_process import open_ring, serve
from wiithrow.app.ros2 import messages as m
from wiithrow.app.ros2.domain import Ros2Domain
from wiithrow.app.ros2.participant import Ros2Node
from wiithrow.app.ros2.process_publisher import DOTS_READ, SAMPLES_UNREAD, SAMPLES_WRITTEN, SUBSCRIBERS
from wiithrow.app.ros2.publisher import Ros2Publisher, transform


def main(config: dict[str, Any]) -> int:
    ring = open_ring(config)
    try:
        domain = Ros2Domain(int(config["domain_id"]), str(config["config"]), node=Ros2Node(**config["node"]))
    except AppError as exc:  # one line, what the caller shows (`WriterProcess`: the child's last line)
        print(exc, file=sys.stderr, flush=True)
        return 1
    except Exception as exc:  # (the binding itself did not load)
        print(f"cannot open DDS domain {config['domain_id']}: {type(exc).__name__}: {exc}", file=sys.stderr, flush=True)
        return 1
    publisher = Ros2Publisher(domain, config["cameras"], config["frame_name"], namespace=config["namespace"])

    def on_records(batch: list[bytes]) -> None:
        for data in batch:
            record = records.unpack(data)
            if isinstance(record, records.Markers):
                publisher.publish_markers(record.frame, m.stamp(record.stamp_ns), seq=record.seq)
            elif isinstance(record, records.Dots):
                publisher.publish_dots(record.camera, record.frame, m.stamp(record.stamp_ns))
            elif isinstance(record, records.Pose):
                publisher.publish_transforms([transform(record.T, "base", "link1", m.stamp(record.stamp_ns))])
            elif isinstance(record, records.Calibration):
                publisher.publish_calibration(record.Ps)
        if batch:
            ring.report(SAMPLES_WRITTEN, publisher.samples_written)

    def on_message(message: dict[str, Any]) -> None:
        if "throw" in message:
            publisher.publish_throw_text(str(message["throw"]))

    def on_idle() -> None:
        ring.report(DOTS_READ, publisher.dots_read())  # before the markers' readers: who waits for those sees these
        ring.report(SUBSCRIBERS, publisher.subscribers())
        ring.report(SAMPLES_WRITTEN, publisher.samples_written)
        ring.report(SAMPLES_UNREAD, publisher.samples_unread)

    try:
        on_idle()
        return serve("ROS 2", ring, on_records, on_message, on_idle)
    finally:
        publisher.drain()
        on_idle()
        domain.close()
        ring.close()


if __name__ == "__main__":
    sys.exit(main(json.loads(sys.argv[1])))
