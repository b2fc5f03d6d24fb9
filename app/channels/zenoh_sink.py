"""The Zenoh sink: `RigPublisher` puts a rig's frames and throws on the keys of
`wiithrow.app.network.messages`; `ZenohProcessPublisher`, what `--publish` runs, is it in a writer
process (`sink_process`).

`RigPublisher` declares one publisher per key (markers, each camera's dots, throws, and who
publishes), JSON-encoded, reliable and with congestion control BLOCK: a slow subscriber slows the
publisher rather than losing frames (at the rig's 100 Hz a frame is a few hundred bytes). Each key
counts its own `seq` from 0, so a subscriber sees a lost or reordered frame; every message says who
sent it (`messages.Sender`: the session's Zenoh id and a stream id drawn at start, `announcement()`),
and every sample is signed with the user's secret (its attachment, `frame_auth.FrameSigner`: the
receiver adopts nothing unsigned). Before its first marker frame, and every `ANNOUNCE_EVERY_S` after
it, the publisher says where it runs on `publisher` (`messages.Origin`: host, pid, command), what
the operator is shown before following it. Puts are serialised by a lock.

Why a writer process: with congestion control BLOCK a put waits while the link's queue is full,
and the rig's thread must never wait for a subscriber; a thread of the tracking process, woken per
frame, waits for the interpreter while the rig's thread and the dashboard's refresh run
(`wiithrow bench latency` measures it). So `ZenohProcessPublisher` packs each frame, numbered (its
key's `seq`), with its velocity and filtered estimate, on the rig's thread (`SinkProcess`: a few
microseconds), and the child (`zenoh_writer`) owns the Zenoh session and a `RigPublisher`: the
same keys, options and payloads (`sent`: the Unix time when the child built the message, just
before the put), so every subscriber reads it unchanged. Of a session's messages it carries the
throws (`post`: a throw's `index` and `result`, its outcome). It runs at its parent's priority
(`WRITER_NICE`): its latency is the point.

The configuration: the child opens the session with `zenoh_session.open_session` from the same
file and `--insecure-network` (by default the loopback peer that meets the others on the local
port; the environment, `$WIITHROW_ZENOH_PORT` and `RUST_LOG`, is inherited); the file is read and
checked here first too (`load_config`, `check_exposure`), so that a bad file or a configuration
open past loopback is the same one line and the `--insecure-network` warning is said where the
operator reads it. The secret that signs every frame (`frame_auth`) is read (made on first use)
here first too, so that a bad secret file is one line before the child starts; the child reads
the same file (the environment, `$WIITHROW_SECRET_FILE` too, is inherited: the secret never
travels in a command line) and announces this process as the publisher's origin.

What the child tells back: its Zenoh id and stream (`SENDER`, in a second, small ring, before it
says it is ready: what `announcement` says and `serve --markers-source` pins); whether the markers
have a subscriber and how many puts it made (`SUBSCRIBERS`, `MARKERS_PUT`, `DOTS_PUT`,
`THROWS_PUT`, the ring's header, every ~50 ms and at its end); with `stamp_puts`, when each tracked
frame's put returned (`PUT` records, CLOCK_MONOTONIC: `put_stamps`, what `bench latency` stamps the
publisher with).
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

from wiithrow.app.channels import records
from wiithrow.app.channels import registry as r
from wiithrow.app.channels.sink_process import SinkProcess
from wiithrow.app.errors import AppError
from wiithrow.app.network.frame_auth import FrameSigner, load_secret, secret_path
from wiithrow.app.network.messages import (
    MarkerRows,
    Origin,
    Sender,
    dots_key,
    dots_message,
    markers_key,
    markers_message,
    publisher_key,
    publisher_message,
    throw_message,
    throws_key,
)
from wiithrow.app.network.zenoh_session import check_exposure, load_config
from wiithrow.clock import Clock
from wiithrow.vision.tracked_frame import TrackedFrame
from wiithrow.vision.wiimote.frames import IRFrame

#: How often a publisher says where it runs (s): a subscriber that starts later learns it within this.
ANNOUNCE_EVERY_S = 1.0


class RigPublisher:
    """Puts one rig's markers, dots and throws on `wiithrow/<rig>/...` through `zenoh_session`
    (open), signed with `signer` (default: this user's secret); `origin`: where it runs (default:
    this process; a writer process names the process it writes for)."""

    def __init__(
        self,
        zenoh_session: Any,
        rig: str,
        camera_names: Sequence[str],
        frame_name: str,
        *,
        origin: Origin | None = None,
        signer: FrameSigner | None = None,
    ) -> None:
        import zenoh

        options = {
            "encoding": zenoh.Encoding.APPLICATION_JSON,
            "congestion_control": zenoh.CongestionControl.BLOCK,
            "reliability": zenoh.Reliability.RELIABLE,
        }
        self.rig = rig
        self.frame_name = frame_name
        self.camera_names = list(camera_names)
        self.sender = Sender.of(zenoh_session)
        self.origin = origin if origin is not None else Origin.of_this_process()
        self.signer = signer if signer is not None else FrameSigner.for_this_user()
        self._keys = {
            "markers": markers_key(rig),
            "throws": throws_key(rig),
            "publisher": publisher_key(rig),
            **{f"dots{i}": dots_key(rig, name) for i, name in enumerate(self.camera_names)},
        }
        self._markers = zenoh_session.declare_publisher(self._keys["markers"], **options)
        self._dots = [
            zenoh_session.declare_publisher(self._keys[f"dots{i}"], **options) for i in range(len(camera_names))
        ]
        self._throws = zenoh_session.declare_publisher(self._keys["throws"], **options)
        self._publisher = zenoh_session.declare_publisher(self._keys["publisher"], **options)
        self.markers_sent = 0
        self.dots_sent = [0] * len(self.camera_names)
        self.throws_sent = 0
        self.announcements_sent = 0
        self._announced_at = -float("inf")
        self._lock = threading.Lock()

    def _put(self, publisher: Any, key: str, text: str) -> None:
        """Put `text` on `key` with its signature (the caller holds the lock)."""
        data = text.encode("utf-8")
        publisher.put(data, attachment=self.signer.sign(key, data))

    def _announce_if_due(self) -> None:
        """Say where this publisher runs, before its first marker frame and every ANNOUNCE_EVERY_S."""
        now = time.monotonic()
        if now - self._announced_at < ANNOUNCE_EVERY_S:
            return
        self._announced_at = now
        message = publisher_message(self.rig, self.announcements_sent, self.origin, sender=self.sender)
        self._put(self._publisher, self._keys["publisher"], message)
        self.announcements_sent += 1

    def publish_markers(
        self, frame: TrackedFrame | MarkerRows, sent: float | None = None, *, seq: int | None = None
    ) -> int:
        """Put one tracked frame (or its values, `MarkerRows`); its seq. `sent`: the Unix time to
        stamp (default: now); `seq`: the number another process gave it (`ZenohProcessPublisher`;
        default: the next)."""
        with self._lock:
            seq = self.markers_sent if seq is None else seq
            self._announce_if_due()
            message = markers_message(self.rig, seq, frame, self.frame_name, sent, sender=self.sender)
            self._put(self._markers, self._keys["markers"], message)
            self.markers_sent = seq + 1
            return seq

    def publish_dots(self, camera: int, frame: IRFrame, *, seq: int | None = None) -> int:
        with self._lock:
            seq = self.dots_sent[camera] if seq is None else seq
            self._put(
                self._dots[camera],
                self._keys[f"dots{camera}"],
                dots_message(self.rig, seq, camera, frame, sender=self.sender),
            )
            self.dots_sent[camera] = seq + 1
            return seq

    def publish_throw(self, index: int, result: dict[str, Any]) -> int:
        with self._lock:
            seq = self.throws_sent
            self._put(
                self._throws, self._keys["throws"], throw_message(self.rig, seq, index, result, sender=self.sender)
            )
            self.throws_sent += 1
            return seq

    def publish_calibration(self, Ps: NDArray[np.float64] | None) -> None:
        """Nothing: the Zenoh keys carry no calibration (a subscriber checks against its own settings)."""

    def has_subscribers(self) -> bool:
        """Whether a subscriber of the markers is known (Zenoh's matching status)."""
        status = self._markers.matching_status  # a MatchingStatus in zenoh 1.x (its stub says bool)
        return bool(getattr(status, "matching", status))

    def wait_for_subscribers(self, timeout_s: float) -> bool:
        """Wait up to `timeout_s` for a subscriber of the markers; whether one came."""
        end = time.monotonic() + timeout_s
        while not self.has_subscribers():
            if time.monotonic() >= end:
                return False
            time.sleep(0.01)
        return True

    def announcement(self) -> str:
        """Who publishes (what a subscriber pins: `serve --markers-source`), said once at start."""
        return (
            f"publishing under wiithrow/{self.rig}/ as source {self.sender.source}, stream {self.sender.stream}, "
            f"signed with this user's secret ({secret_path()})"
        )

    def summary(self) -> str:
        dots = sum(self.dots_sent)
        return (
            f"published {self.markers_sent} marker frames, {dots} camera frames and {self.throws_sent} throws "
            f"under wiithrow/{self.rig}/"
        )

    def close(self) -> None:
        with self._lock:
            for publisher in [self._markers, *self._dots, self._throws, self._publisher]:
                try:
                    publisher.undeclare()
                except Exception:  # the session closed first: nothing left to undeclare
                    pass


#: The child's figures in the ring's header (`FrameRing.report`).
SUBSCRIBERS, MARKERS_PUT, DOTS_PUT, THROWS_PUT = 3, 4, 5, 6
WHAT = "Zenoh"
#: The child's niceness above its parent's: none, unlike ROS 2's and Foxglove's writers
#: (`writer_process.WRITER_NICE`): its latency is the point, the in-process publisher's thread it
#: replaces ran at the tracking's priority, and its work is small (~0.1 ms a frame, ~1% of a core).
WRITER_NICE = 0
#: The answers' ring: ~40 s of `PUT` stamps at 100 Hz.
BACK_SLOTS = 4096


def carries(topic: str) -> bool:
    """The session messages Zenoh carries: the throws."""
    return topic == r.THROWS.topic


class ZenohProcessPublisher(SinkProcess):
    """`RigPublisher(rig, camera_names, frame_name)` in a writer process (module docstring)."""

    def __init__(
        self,
        rig: str,
        camera_names: Sequence[str],
        frame_name: str,
        *,
        clock: Clock,
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
        self._back_lock = threading.Lock()  # one reader of the answers
        super().__init__(
            WHAT,
            "wiithrow.app.channels.zenoh_writer",
            {
                "rig": rig,
                "frame_name": frame_name,
                "zenoh_config": None if config_file is None else os.path.abspath(config_file),
                "insecure_network": bool(insecure_network),
                "stamp_puts": bool(stamp_puts),
                "origin": Origin.of_this_process().fields(),
            },
            clock=clock,
            cameras=camera_names,
            vectors=True,
            back_slots=BACK_SLOTS,
            carries=carries,
            nice=WRITER_NICE,
            on_failure=on_failure,
        )
        senders = [a for a in self._answers() if isinstance(a, records.SenderRecord)]
        if not senders:
            self.process.close()
            if self.back is not None:
                self.back.close()
            raise AppError(f"{WHAT}: the writer process said it was ready without saying who it publishes as")
        self.source, self.stream = senders[0].source, senders[0].stream

    def _answers(self) -> list[records.Record]:
        with self._back_lock:
            if self.back is None or self.back.closed:
                return []
            return [records.unpack(a) for a in self.back.read()]

    def put_stamps(self) -> list[tuple[float, float]]:
        """(t, when its put returned: `time.monotonic`'s seconds) of each tracked frame the child put
        since the last call (with `stamp_puts`)."""
        return [(a.t, a.at_ns * 1e-9) for a in self._answers() if isinstance(a, records.Put)]

    @property
    def markers_put(self) -> int:
        return self.figure(MARKERS_PUT)

    @property
    def dots_put(self) -> int:
        return self.figure(DOTS_PUT)

    @property
    def throws_put(self) -> int:
        return self.figure(THROWS_PUT)

    def has_subscribers(self) -> bool:
        """Whether the child knows a subscriber of the markers (Zenoh's matching status, told every ~50 ms)."""
        return bool(self.figure(SUBSCRIBERS))

    def wait_for_subscribers(self, timeout_s: float) -> bool:
        """Wait up to `timeout_s` for a subscriber of the markers; whether one came."""
        end = time.monotonic() + timeout_s
        while not self.has_subscribers():
            if time.monotonic() >= end or not self.process.alive():
                return False
            time.sleep(0.01)
        return True

    def close(self) -> None:
        with self._back_lock:
            super().close()

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
