"""The Zenoh writer process: `python -m wiithrow.app.network.zenoh_writer CONFIG` (`ZenohProcessPublisher`).

Opens the Zenoh session as the tracking process would have (`open_session`, with `CONFIG`'s
`zenoh_config` and `insecure_network`; `CONFIG` is JSON: also the rig's name, cameras and frame,
and the two `FrameRing`s), declares a `RigPublisher` on it (signing with this user's secret, announcing the tracking
process's `origin`: its host, pid and command), tells who it publishes as (`SENDER`,
in the ring `back`) and then puts each record of the ring as the in-process publisher would: a
`Markers` record on `markers` and a `Dots` record on its camera's `dots`, with the tracking
process's `seq`; a `{"throw": JSON}` line on stdin on `throws`. With `stamp_puts`, each tracked
frame's put is stamped when it returned (`PUT`, CLOCK_MONOTONIC). Its figures (a subscriber of
the markers, the puts made) go to the main ring's header. Ends when stdin closes
(`writer_process.serve`), after the last records, undeclaring and closing the session.
"""

from __future__ import annotations

import json
import sys
import time
from typing import Any

from wiithrow.app.errors import AppError
from wiithrow.app.network import zenoh_records as records
from wiithrow.app.network.frame_ring import FrameRing
from wiithrow.app.network.messages import Origin
from wiithrow.app.network.process_publisher import DOTS_PUT, MARKERS_PUT, SUBSCRIBERS, THROWS_PUT, WHAT
from wiithrow.app.network.publisher import RigPublisher
from wiithrow.app.network.writer_process import open_ring, serve
from wiithrow.app.network.zenoh_session import open_session


def main(config: dict[str, Any]) -> int:
    ring = open_ring(config)
    back = FrameRing.open(config["back"], config["back_slots"], config["back_slot_bytes"], -1)  # never woken: polled
    try:
        session = open_session(config["zenoh_config"], insecure_network=bool(config["insecure_network"]))
    except AppError as exc:
        print(exc, file=sys.stderr, flush=True)
        return 1
    try:
        publisher = RigPublisher(
            session, config["rig"], config["cameras"], config["frame_name"], origin=Origin(**config["origin"])
        )
    except AppError as exc:  # the secret file (read by the parent a moment ago)
        print(exc, file=sys.stderr, flush=True)
        session.close()
        return 1
    records.put_sender(back, publisher.sender.source, publisher.sender.stream)
    stamp_puts = bool(config["stamp_puts"])
    puts = {MARKERS_PUT: 0, DOTS_PUT: 0, THROWS_PUT: 0}  # (counted here: a record's seq skips what was lost)

    def on_records(batch: list[bytes]) -> None:
        # a batch's tracked frames first, then its dots: a frame's dots are packed just before the
        # tracked frame they complete (`RigFollower`), which put behind them waited for their JSON
        # and puts (and, since the child is woken once per poll, behind their unpacking: a child
        # woken after 10 ms asleep runs cold, an unpack then costs ~0.1 ms); each key keeps its
        # order (a subscriber orders by key and `seq`, never across keys)
        for data in batch:
            if records.kind_of(data) == records.MARKERS:
                seq, rows = records.unpack_marker_rows(data)  # (no numpy: each call runs cold)
                publisher.publish_markers(rows, seq=seq)
                puts[MARKERS_PUT] += 1
                if stamp_puts:
                    records.put_put(back, rows.t, time.monotonic_ns())
        for data in batch:
            kind = records.kind_of(data)
            if kind == records.DOTS:
                dots = records.unpack(data)
                assert isinstance(dots, records.Dots)
                publisher.publish_dots(dots.camera, dots.frame, seq=dots.seq)
                puts[DOTS_PUT] += 1
            elif kind != records.MARKERS:
                records.unpack(data)  # ValueError for a kind of no Zenoh record, as before
        if batch:
            report_puts()

    def on_message(message: dict[str, Any]) -> None:
        if "throw" in message:
            throw = json.loads(message["throw"])
            publisher.publish_throw(int(throw["index"]), throw["result"])
            puts[THROWS_PUT] += 1
            report_puts()

    def report_puts() -> None:
        for index, count in puts.items():
            ring.report(index, count)

    def on_idle() -> None:
        ring.report(SUBSCRIBERS, int(publisher.has_subscribers()))

    try:
        on_idle()
        return serve(WHAT, ring, on_records, on_message, on_idle, nice=int(config["nice"]))
    finally:
        publisher.close()
        session.close()
        report_puts()
        ring.close()
        back.close()


if __name__ == "__main__":
    sys.exit(main(json.loads(sys.argv[1])))
