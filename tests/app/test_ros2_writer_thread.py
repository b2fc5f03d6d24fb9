"""The ROS 2 publisher's writer thread (`thread=True`; issue 24: `bench tracking` unchanged with
`--ros2`): the tracking thread only queues a frame; when the writer is behind by `QUEUE_FRAMES`, a frame is
dropped and counted, and the caller is never blocked; what was queued is written in order."""

from __future__ import annotations

import os
import threading
import time
import uuid

import numpy as np

from wiithrow.app.ros2 import publisher as p
from wiithrow.app.ros2.domain import LOOPBACK_CONFIG, Ros2Domain
from wiithrow.vision.tracked_frame import TrackedFrame


def _frame() -> TrackedFrame:
    n = 2
    return TrackedFrame(
        t=0.0,
        ids=np.arange(n),
        position=np.zeros((n, 3)),
        velocity=np.zeros((n, 3)),
        filtered=np.zeros((n, 3)),
        visible=np.ones(n, bool),
        n_views=np.full(n, 2),
    )


def test_a_full_queue_drops_and_counts_frames_and_never_blocks_the_caller():
    domain = Ros2Domain(100 + os.getpid() % 100, LOOPBACK_CONFIG)
    try:
        publisher = p.Ros2Publisher(domain, ["cam0"], "link1", namespace=f"/t{uuid.uuid4().hex[:8]}", thread=True)
        written: list[int] = []
        real_write, gate = publisher._write, threading.Event()

        def slow_write(item: p._Write) -> None:  # a writer that is behind: frame 0's write waits for the gate
            written.append(item.index)
            gate.wait(10.0)
            real_write(item)

        publisher._write = slow_write  # type: ignore[method-assign]
        frame = _frame()
        publisher.publish_markers(frame)
        end = time.monotonic() + 10.0
        while not written and time.monotonic() < end:  # until the writer holds frame 0
            time.sleep(0.001)
        assert written == [0]
        extra = 7
        done = threading.Event()

        def flood() -> None:
            for _ in range(p.QUEUE_FRAMES + extra):
                publisher.publish_markers(frame)
            done.set()

        threading.Thread(target=flood, daemon=True).start()
        assert done.wait(10.0), "publish_markers blocked behind a write in flight"
        assert publisher.markers_dropped == extra
        assert publisher.markers_sent == 1 + p.QUEUE_FRAMES + extra  # every frame numbered, sent or not
        gate.set()
        assert publisher.flush(10.0)
        assert written == list(range(1 + p.QUEUE_FRAMES))  # the queued ones, in order; the dropped never
        assert "7 marker and 0 camera frames dropped" in publisher.summary()
        # no reader of markers or markers/visualization: nothing was encoded
        assert (publisher.samples_written, publisher.samples_unread) == (0, 2 * len(written))
        publisher.drain(0.1)
    finally:
        domain.close()
