"""`Ros2ProcessPublisher`: the ROS 2 publisher in a writer process of its own, fed through shared memory.

What `--ros2` runs. The tracking process keeps
only the hand-over (~2 us a frame, measured): each frame is stamped (Unix time, now: the messages' header stamps), numbered
(the Markers' `frame_number`) and packed into a `FrameRing` (`frame_records`), and `/tf`'s
base -> link1 is sampled from the arm every `TF_PERIOD_S` as a record too; a throw is one JSON
line to the child. The child (`writer_main`, started by `WriterProcess`) owns the DDS domain and
a `Ros2Publisher` (same topics, types, QoS and CDR bytes as in-process: docs/integrations/ros2.md) and
writes each record as it comes. A camera's dots are handed over only while its topic has a
reader (the child tells which: `DOTS_READ`; a best-effort sample nobody reads reaches no one).

A slow or stopped child never stalls the tracking: the ring overwrites its oldest records
(`RING_SLOTS`, ~8 s of a 4-camera rig at 100 Hz), and the child counts what it lost
(`frames_dropped`, told in `summary`). A child that ends on its own is one line on stderr (and
in `summary`); the child ends when this process closes it or ends (`WriterProcess`).
"""

from __future__ import annotations

import sys
import threading
import time
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np
from numpy.typing import NDArray

from wiithrow.app.network import frame_records as records
from wiithrow.app.network.frame_ring import FrameRing
from wiithrow.app.network.writer_process import WriterProcess
from wiithrow.app.ros2.domain import LOOPBACK_CONFIG, topic_name
from wiithrow.app.ros2.participant import Ros2Node
from wiithrow.app.ros2.publisher import DEFAULT_NAMESPACE, ArmPoseSampler
from wiithrow.vision.files import dumps_strict
from wiithrow.vision.tracked_frame import TrackedFrame
from wiithrow.vision.wiimote.frames import IRFrame

RING_SLOTS = 4096
#: The child's figures in the ring's header (`FrameRing.report`).
SUBSCRIBERS, SAMPLES_WRITTEN, SAMPLES_UNREAD, DOTS_READ = 3, 4, 5, 6


class Ros2ProcessPublisher:
    """The `Ros2Publisher` of `domain_id` / `config` in a writer process (module docstring), with
    its interface: what `RigFollower` and `Ros2Publishing` call. The child's participant is ROS 2
    node `node` (default: `participant.DEFAULT_NODE_NAME` in `namespace`)."""

    def __init__(
        self,
        domain_id: int,
        camera_names: Sequence[str],
        frame_name: str,
        *,
        config: str = LOOPBACK_CONFIG,
        namespace: str = DEFAULT_NAMESPACE,
        arm_pose: Callable[[], NDArray[np.float64] | None] | None = None,
        on_failure: Callable[[str], None] | None = None,
        node: Ros2Node | None = None,
    ) -> None:
        self.domain_id = domain_id
        self.node = Ros2Node(namespace=namespace) if node is None else node  # its participant's ROS 2 node
        self.namespace = namespace
        self.frame_name = frame_name
        self.camera_names = list(camera_names)
        self.arm_pose = arm_pose
        self.topics = {name: topic_name(namespace, name) for name in ("markers", "markers/visualization", "throws")}
        self.markers_sent = 0
        self.dots_sent = [0] * len(self.camera_names)
        self.tf_sent = 0
        self.throws_sent = 0
        self._arm_samples = ArmPoseSampler(arm_pose)
        self._lock = threading.Lock()  # one record at a time (the follower's thread, a calibration)
        self.ring = FrameRing.create(RING_SLOTS, records.SLOT_BYTES)
        try:
            self.process = WriterProcess(
                "ROS 2",
                "wiithrow.app.ros2.writer_main",
                self.ring,
                {
                    "domain_id": domain_id,
                    "config": config,
                    "cameras": self.camera_names,
                    "frame_name": frame_name,
                    "namespace": namespace,
                    "node": {"name": self.node.name, "namespace": self.node.namespace, "distro": self.node.distro},
                },
                on_failure=on_failure,
            )
        except BaseException:
            self.ring.close()
            raise

    # -- the hand-over (the tracking thread, or the follower's)

    def publish_markers(self, frame: TrackedFrame) -> int:
        stamp_ns = time.time_ns()
        with self._lock:
            seq = self.markers_sent
            self.markers_sent += 1
            if self.ring.closed:
                return seq
            records.put_markers(self.ring, seq, frame, stamp_ns)
            self.ring.wake()
        return seq

    def publish_dots(self, camera: int, frame: IRFrame) -> int:
        stamp_ns = time.time_ns()
        with self._lock:
            seq = self.dots_sent[camera]
            self.dots_sent[camera] += 1
            if self.ring.closed:
                return seq
            self._sample_arm(stamp_ns)
            if not self.ring.figure(DOTS_READ) >> camera & 1:  # no reader of its dots: nothing to hand over
                return seq
            records.put_dots(self.ring, camera, frame, stamp_ns)
            self.ring.wake()
        return seq

    def _sample_arm(self, stamp_ns: int) -> None:
        T = self._arm_samples.due()
        if T is not None:
            records.put_pose(self.ring, T, stamp_ns)
            self.tf_sent += 1

    def publish_calibration(self, Ps: NDArray[np.float64] | None) -> None:
        if Ps is None:
            return
        with self._lock:
            if not self.ring.closed:
                records.put_calibration(self.ring, Ps)
                self.ring.wake()

    def publish_throw(self, index: int, result: dict[str, Any]) -> int:
        """One throw (a JSON line to the child: not the tracking thread's business)."""
        seq = self.throws_sent
        self.process.send({"throw": dumps_strict({"index": index, "result": result})})
        self.throws_sent += 1
        return seq

    # -- what the child tells

    @property
    def failure(self) -> str | None:
        return self.process.failure

    @property
    def frames_dropped(self) -> int:
        """Records the child lost: the ring came round before it read them."""
        return self.ring.dropped

    @property
    def samples_written(self) -> int:
        return self.ring.figure(SAMPLES_WRITTEN)

    @property
    def samples_unread(self) -> int:
        return self.ring.figure(SAMPLES_UNREAD)

    def subscribers(self) -> int:
        """How many readers of `markers` the child has matched (told every ~50 ms)."""
        return self.ring.figure(SUBSCRIBERS)

    def wait_for_subscribers(self, timeout_s: float, count: int = 1) -> bool:
        end = time.monotonic() + timeout_s
        while self.subscribers() < count:
            if time.monotonic() >= end or not self.process.alive():
                return False
            time.sleep(0.01)
        return True

    def flush(self, timeout_s: float = 2.0) -> bool:
        """Wait until the child has read (and written) every record so far; whether it did in time."""
        return self.process.wait_until_read(timeout_s)

    def drain(self, timeout_s: float = 1.0) -> None:
        """End the child after what it was handed (it drains its writers: `Ros2Publisher.drain`)."""
        self.flush(timeout_s)
        with self._lock:
            self.process.close()

    close = drain

    def announcement(self) -> str:
        return (
            f"ROS 2 topics under {self.namespace or '/'} (and /tf, /tf_static) on DDS domain {self.domain_id}, "
            f"node {self.node.namespace}/{self.node.name} ({self.node.distro}'s graph; a writer process, pid "
            f"{self.process.pid})"
        )

    def summary(self) -> str:
        return (
            f"published {self.markers_sent} marker frames, {sum(self.dots_sent)} camera frames, {self.tf_sent} /tf "
            f"and {self.throws_sent} throws as ROS 2 topics under {self.namespace or '/'}"
            + (f" ({self.frames_dropped} frames dropped: the writer process was behind)" if self.frames_dropped else "")
            + (f"; writing stopped: {self.failure}" if self.failure else "")
        )


def tell_failure(command: str) -> Callable[[str], None]:
    """What `on_failure` does on the command line: one line on stderr."""

    def tell(failure: str) -> None:
        print(f"wiithrow {command}: {failure}; tracking goes on without ROS 2", file=sys.stderr, flush=True)

    return tell
