"""`ZenohProcessPublisher`: what `--publish` runs: `RigPublisher` in a writer process of its own, fed
through shared memory.

Why: a put on a thread of the tracking process waits for the interpreter while the rig's thread
and the dashboard's refresh run (`wiithrow bench latency`'s publisher figure, docs/journal.md). Here the
tracking process keeps only the hand-over: each camera frame and each tracked frame is numbered
(its key's `seq`) and packed into a `FrameRing` (`zenoh_records`, a few microseconds, on the rig's
thread, under its lock: `RigFollower(inline=True)`); a throw is one JSON line to the child
(`WriterProcess.send`, from the thread that threw). The child (`zenoh_writer`) owns the Zenoh
session and a `RigPublisher`: the same key expressions, options and payloads as in-process (its
`sent` is the Unix time when the child built the message, just before the put, as in-process),
so every subscriber reads it unchanged.

The configuration: the child opens the session with `zenoh_session.open_session` from the same
file and `--insecure-network` (by default the loopback peer that meets the others on the local
port; the environment, `$WIITHROW_ZENOH_PORT` and `RUST_LOG`, is inherited); the file is read and
checked here first too (`load_config`, `check_exposure`), so that a bad file or a configuration
open past loopback is the same one line as before and the `--insecure-network` warning is said
where the operator reads it. A session that cannot open is the child's one line (`WriterProcess`).

The secret that signs every frame (`frame_auth`) is read (made on first use) here first, so that a
bad secret file is one line before the child starts; the child reads the same file (the
environment, `$WIITHROW_SECRET_FILE` too, is inherited: the secret never travels in a command line).
The child announces this process as the publisher's origin (`messages.Origin`: host, pid, command),
what an operator confirms on the receiving side.

What the child tells back: its Zenoh id and stream (`SENDER`, before it says it is ready: what
`announcement` says and `serve --markers-source` pins), in a second, small ring (`back`); whether
the markers have a subscriber and how many puts it made (`SUBSCRIBERS`, `MARKERS_PUT`,
`DOTS_PUT`, `THROWS_PUT`, the main ring's header, every ~50 ms and at its end); with
`stamp_puts`, when each tracked frame's put returned (`PUT` records, CLOCK_MONOTONIC: `put_stamps`,
what `bench latency` stamps the publisher with).

A slow or stopped child never stalls the tracking: the ring overwrites its oldest records
(`RING_SLOTS`, ~27 s of a two-camera rig at 100 Hz), the child counts what it lost
(`records_dropped`, in `summary`), and a subscriber sees the gap in `seq`. A child that ends on its
own is one line on stderr (`on_failure`) and in `summary`; the tracking goes on.
"""

from __future__ import annotations

import os
import sys
import threading
import time
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np
from numpy.typing import NDArray

from wiithrow.app.errors import AppError
from wiithrow.app.network import zenoh_records as records
from wiithrow.app.network.frame_auth import load_secret, secret_path
from wiithrow.app.network.frame_ring import FrameRing
from wiithrow.app.network.messages import Origin
from wiithrow.app.network.writer_process import WriterProcess
from wiithrow.app.network.zenoh_session import check_exposure, load_config
from wiithrow.vision.files import dumps_strict
from wiithrow.vision.tracked_frame import TrackedFrame
from wiithrow.vision.wiimote.frames import IRFrame

RING_SLOTS = 8192
BACK_SLOTS = 4096
#: The child's figures in the main ring's header (`FrameRing.report`).
SUBSCRIBERS, MARKERS_PUT, DOTS_PUT, THROWS_PUT = 3, 4, 5, 6
WHAT = "Zenoh"
#: The child's niceness above its parent's: none, unlike ROS 2's and Foxglove's writers
#: (`writer_process.WRITER_NICE`): its latency is the point, the in-process publisher's
#: thread it replaces ran at the tracking's priority, and its work is small (~0.1 ms a frame, ~1% of a core).
WRITER_NICE = 0


class ZenohProcessPublisher:
    """`RigPublisher(rig, camera_names, frame_name)` in a writer process (module docstring): what
    `RigFollower` and `Publishing` call."""

    def __init__(
        self,
        rig: str,
        camera_names: Sequence[str],
        frame_name: str,
        *,
        config_file: str | os.PathLike[str] | None = None,
        insecure_network: bool = False,
        stamp_puts: bool = False,
        on_failure: Callable[[str], None] | None = None,
    ) -> None:
        if config_file is not None:  # what open_session checks, said here (the child checks it again)
            check_exposure(load_config(config_file), config_file, insecure_network)
        load_secret()  # a bad secret file is one line here, before the child starts
        self.rig = rig
        self.frame_name = frame_name
        self.camera_names = list(camera_names)
        self.markers_sent = 0
        self.dots_sent = [0] * len(self.camera_names)
        self.throws_sent = 0
        self.too_large = 0
        self._lock = threading.Lock()  # one writer of the ring at a time
        self._back_lock = threading.Lock()  # one reader of the answers
        self.ring = FrameRing.create(RING_SLOTS, records.SLOT_BYTES)
        self.back = FrameRing.create(BACK_SLOTS, records.BACK_SLOT_BYTES)
        try:
            self.process = WriterProcess(
                WHAT,
                "wiithrow.app.network.zenoh_writer",
                self.ring,
                {
                    "back": self.back.name,
                    "back_slots": self.back.slots,
                    "back_slot_bytes": self.back.slot_bytes,
                    "rig": rig,
                    "cameras": self.camera_names,
                    "frame_name": frame_name,
                    "zenoh_config": None if config_file is None else os.path.abspath(config_file),
                    "insecure_network": bool(insecure_network),
                    "stamp_puts": bool(stamp_puts),
                    "origin": Origin.of_this_process().fields(),
                    "nice": WRITER_NICE,
                },
                on_failure=on_failure,
            )
        except BaseException:
            self.ring.close()
            self.back.close()
            raise
        senders = [r for r in self._answers() if isinstance(r, records.SenderRecord)]
        if not senders:
            self.process.close()
            self.back.close()
            raise AppError(f"{WHAT}: the writer process said it was ready without saying who it publishes as")
        self.source, self.stream = senders[0].source, senders[0].stream

    # -- the hand-over (the rig's thread, under its lock: never waits)

    def publish_markers(self, frame: TrackedFrame) -> int:
        with self._lock:
            seq = self.markers_sent
            self.markers_sent += 1
            if self.ring.closed:
                return seq
            try:
                records.put_markers(self.ring, seq, frame)
            except records.TooLarge as exc:
                self.too_large += 1
                if self.too_large == 1:
                    print(f"wiithrow: {WHAT} publisher: {exc}: such frames are not published", file=sys.stderr)
                return seq
            self.ring.wake()
        return seq

    def publish_dots(self, camera: int, frame: IRFrame) -> int:
        with self._lock:
            seq = self.dots_sent[camera]
            self.dots_sent[camera] += 1
            if self.ring.closed:
                return seq
            records.put_dots(self.ring, camera, seq, frame)
            self.ring.wake()
        return seq

    def publish_calibration(self, Ps: NDArray[np.float64] | None) -> None:
        """Nothing: the Zenoh keys carry no calibration (`RigPublisher.publish_calibration`)."""

    def publish_throw(self, index: int, result: dict[str, Any]) -> int:
        """One throw: a JSON line to the child (blocking: not for the rig's thread)."""
        text = dumps_strict({"index": index, "result": result})  # what cannot be JSON fails here, as in-process
        seq = self.throws_sent
        self.process.send({"throw": text})
        self.throws_sent += 1
        return seq

    # -- what the child tells

    def _answers(self) -> list[records.Record]:
        with self._back_lock:
            if self.back.closed:
                return []
            return [records.unpack(r) for r in self.back.read()]

    def put_stamps(self) -> list[tuple[float, float]]:
        """(t, when its put returned: `time.monotonic`'s seconds) of each tracked frame the child put
        since the last call (with `stamp_puts`)."""
        return [(r.t, r.at_ns * 1e-9) for r in self._answers() if isinstance(r, records.Put)]

    @property
    def failure(self) -> str | None:
        return self.process.failure

    @property
    def records_dropped(self) -> int:
        """Records the child lost: the ring came round before it read them."""
        return self.ring.dropped

    @property
    def markers_put(self) -> int:
        return self.ring.figure(MARKERS_PUT)

    @property
    def dots_put(self) -> int:
        return self.ring.figure(DOTS_PUT)

    @property
    def throws_put(self) -> int:
        return self.ring.figure(THROWS_PUT)

    def has_subscribers(self) -> bool:
        """Whether the child knows a subscriber of the markers (Zenoh's matching status, told every ~50 ms)."""
        return bool(self.ring.figure(SUBSCRIBERS))

    def wait_for_subscribers(self, timeout_s: float) -> bool:
        """Wait up to `timeout_s` for a subscriber of the markers; whether one came."""
        end = time.monotonic() + timeout_s
        while not self.has_subscribers():
            if time.monotonic() >= end or not self.process.alive():
                return False
            time.sleep(0.01)
        return True

    def flush(self, timeout_s: float = 2.0) -> bool:
        """Wait until the child has read (and put) every record so far; whether it did in time."""
        return self.process.wait_until_read(timeout_s)

    def close(self) -> None:
        """End the child after what it was handed (its stdin closes: it puts what the ring holds,
        undeclares and closes its session); its last figures stay readable."""
        self.flush(1.0)
        with self._lock:
            self.process.close()
        with self._back_lock:
            self.back.close()

    def announcement(self) -> str:
        return (
            f"publishing under wiithrow/{self.rig}/ as source {self.source}, stream {self.stream} "
            f"(a writer process, pid {self.process.pid}), signed with this user's secret ({secret_path()})"
        )

    def summary(self) -> str:
        text = (
            f"published {self.markers_put} marker frames, {self.dots_put} camera frames and {self.throws_put} throws "
            f"under wiithrow/{self.rig}/"
        )
        if self.records_dropped:
            text += f" ({self.records_dropped} frames dropped: the writer process was behind)"
        if self.too_large:
            text += f" ({self.too_large} marker frames too large to publish)"
        if self.failure:
            text += f"; publishing stopped: {self.failure}"
        return text


def tell_failure(command: str) -> Callable[[str], None]:
    """What `on_failure` does on the command line: one line on stderr."""

    def tell(failure: str) -> None:
        print(f"wiithrow {command}: {failure}; tracking goes on without publishing", file=sys.stderr, flush=True)

    return tell
