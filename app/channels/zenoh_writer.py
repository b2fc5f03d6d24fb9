"""The Zenoh writer process: `python -m wiithrow.app.channels.zenoh_writer CONFIG` (`ZenohProcessPublisher`).

Opens the Zenoh session as the tracking process would have (`open_session`, with `CONFIG`'s
`zenoh_config` and `insecure_network`; `CONFIG` is JSON: also the rig's name, cameras and frame,
and the two `FrameRing`s), declares a `RigPublisher` on it (signing with this user's secret,
announcing the tracking process's `origin`: its host, pid and command), tells who it publishes as
(`SENDER`, in the ring `back`) and then puts each record of the ring as the in-process publisher
would: a `MARKERS` record on `markers` and a `DOTS` record on its camera's `dots`, with the
tracking process's `seq`; a throw (`{"write": ["/throws", stamp_ns, message]}` on stdin) on
`throws`. With `stamp_puts`, each tracked frame's put is stamped when it returned (`PUT`,
CLOCK_MONOTONIC). Its figures (a subscriber of the markers, the puts made) go to the main ring's
header. Ends when stdin closes (`writer_process.run`), after the last records, undeclaring and
closing the session.
"""

from __future__ import annotations

import json
import sys
import time
from typing import Any

from wiithrow.app.channels import records
from wiithrow.app.channels import registry as r
from wiithrow.app.channels.frame_ring import FrameRing
from wiithrow.app.channels.writer_process import open_back, run
from wiithrow.app.channels.zenoh_sink import DOTS_PUT, MARKERS_PUT, SUBSCRIBERS, THROWS_PUT, WHAT, RigPublisher
from wiithrow.app.network.messages import Origin
from wiithrow.app.network.zenoh_session import open_session


class ZenohWriter:
    """The child's sink: the session, its `RigPublisher`, the records put (module docstring)."""

    def __init__(self, config: dict[str, Any], ring: FrameRing) -> None:
        self.ring = ring
        self.back = open_back(config)
        self.session = open_session(config["zenoh_config"], insecure_network=bool(config["insecure_network"]))
        try:
            self.publisher = RigPublisher(
                self.session, config["rig"], config["cameras"], config["frame_name"], origin=Origin(**config["origin"])
            )
        except BaseException:  # the secret file (read by the parent a moment ago)
            self.session.close()
            raise
        records.put_sender(self.back, self.publisher.sender.source, self.publisher.sender.stream)
        self.stamp_puts = bool(config["stamp_puts"])
        self.puts = {MARKERS_PUT: 0, DOTS_PUT: 0, THROWS_PUT: 0}  # (counted here: a record's seq skips what was lost)

    def on_records(self, batch: list[bytes]) -> None:
        # a batch's tracked frames first, then its dots: a frame's dots are packed just before the
        # tracked frame they complete, which put behind them waited for their JSON and puts (and,
        # since the child is woken once per poll, behind their unpacking: a child woken after
        # 10 ms asleep runs cold, an unpack then costs ~0.1 ms); each key keeps its order (a
        # subscriber orders by key and `seq`, never across keys)
        for data in batch:
            if records.kind_of(data) == records.MARKERS:
                seq, rows = records.unpack_marker_rows(data)  # (no numpy: each call runs cold)
                self.publisher.publish_markers(rows, seq=seq)
                self.puts[MARKERS_PUT] += 1
                if self.stamp_puts:
                    records.put_put(self.back, rows.t, time.monotonic_ns())
        for data in batch:
            if records.kind_of(data) == records.DOTS:
                dots = records.unpack(data)
                assert isinstance(dots, records.Dots)
                self.publisher.publish_dots(dots.camera, dots.frame, seq=dots.seq)
                self.puts[DOTS_PUT] += 1
        if batch:
            self.report_puts()

    def on_message(self, message: dict[str, Any]) -> None:
        topic, _stamp_ns, body = message.get("write", (None, 0, None))
        if topic == r.THROWS.topic:
            document = body["record"]
            self.publisher.publish_throw(int(document["index"]), document["outcome"])
            self.puts[THROWS_PUT] += 1
            self.report_puts()

    def report_puts(self) -> None:
        for index, count in self.puts.items():
            self.ring.report(index, count)

    def on_idle(self) -> None:
        self.ring.report(SUBSCRIBERS, int(self.publisher.has_subscribers()))

    def close(self) -> None:
        self.publisher.close()
        self.session.close()
        self.report_puts()
        self.back.close()


if __name__ == "__main__":
    sys.exit(run(WHAT, json.loads(sys.argv[1]), ZenohWriter))
