"""`SinkProcess`: a sink in a writer process of its own, fed with a rig's events through shared memory.

What `--publish` (Zenoh), `--ros2` and `--foxglove` run, one mechanism for the three. A sink in
the tracking process would pay for its encoding on the tracking thread, or in interpreter-lock
hand-overs with a thread of its own (docs/performance.md: what they cost the tracking loop); here the
tracking process keeps only the hand-over: each event of the followed source is packed, on the thread that tells it, under its
lock (`follow`: `event`), into a `FrameRing` (`records`: a few microseconds), and the child
(`python -m MODULE`, started and watched by `WriterProcess`: its `main` runs `writer_process.run`
with the sink) unpacks and writes it. A session's rarer messages (its URDF, a previewed
trajectory, a throw: `post`) go to the child's stdin as JSON lines, handed over by a sender thread
(`wiithrow-<what>-sender`, at most `QUEUE_MESSAGES` waiting; one more is dropped and counted): the
session's thread never waits on the pipe.

What is packed, per sink (the constructor's flags):
- each camera frame (`DOTS`, numbered per camera), each tracked frame (`MARKERS`, numbered),
  each calibration (`CALIBRATION`, always: it is state a late reader needs);
- `vectors`: a tracked frame's velocity and filtered estimate too (Zenoh's payload has them);
- `framed`: each event whole, its raw reports too, closed by an `END` (Foxglove's channels are a
  recording's, steps and reports included);
- `gated`: only what the child wants now (`WANTS`, a figure it keeps in the ring's header: the
  markers, each camera's dots, the events, the arm: what its readers or clients subscribed to);
  a frame not packed still takes its number;
- with `follow(source, arm=...)`, a session's arm sampled where a camera's frames come (`ARM`,
  at most every `ARM_PERIOD_S` of the rig's clock).
Times are the rig's clock; the child stamps them in Unix time with the offset it is given
(`wall_time`, the clock's one mapping), so that every sink of a run stamps a frame alike.

A slow or stopped child never stalls the tracking: the ring overwrites its oldest records, the
child counts what it lost (`records_dropped`), and a subscriber sees the gap in the numbers. A
child that ends on its own is one line on stderr (`on_failure`); the tracking goes on.
"""

from __future__ import annotations

import queue
import sys
import threading
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np
from numpy.typing import NDArray

from wiithrow.app.channels import records
from wiithrow.app.channels.frame_ring import FrameRing
from wiithrow.app.channels.wall_time import wall_time
from wiithrow.app.channels.writer_process import WRITER_NICE, WriterProcess
from wiithrow.app.rig.events import CalibrationChanged, Flushed, FramesProcessed, RigEvent
from wiithrow.app.rig.source import MarkerSource
from wiithrow.clock import Clock
from wiithrow.fault_lines import FaultLines
from wiithrow.listeners import Unsubscribe
from wiithrow.vision.tracked_frame import TrackedFrame
from wiithrow.vision.wiimote.frames import IRFrame

#: Records of a ring: ~27 s of a two-camera rig at 100 Hz with its events whole.
RING_SLOTS = 8192
#: The figure of the ring's header a gated sink's child keeps: what it wants packed (bits).
WANTS = 6
WANT_MARKERS, WANT_EVENTS, WANT_ARM = 1, 2, 4
WANT_ALL = (1 << 62) - 1
#: A session's messages the sender thread may be behind (a throw, a trajectory: rare).
QUEUE_MESSAGES = 100
SENDER_STOP_S = 2.0


#: A session's arm is sampled at most every 20 ms of the rig's clock (50 Hz), when a camera's frames come.
ARM_PERIOD_S = 0.02

#: An arm's state now: (q, dq, base -> link1 4x4), or None when it cannot say.
ArmState = Callable[[], tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]] | None]


class ArmSampler:
    """`state` asked for at most every `ARM_PERIOD_S` of the rig's clock: `sample(t)` is the arm's
    state when a sample is due at `t`, else None (too soon, or an arm that cannot say where it is
    now: no sample this time)."""

    def __init__(self, state: ArmState) -> None:
        self.state = state
        self._last = -1e9

    def due(self, t: float) -> bool:
        return t - self._last >= ARM_PERIOD_S

    def restart(self) -> None:
        """Sample at the next frame, whenever the last sample was."""
        self._last = -1e9

    def sample(self, t: float) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]] | None:
        if not self.due(t):
            return None
        self._last = t
        try:
            return self.state()
        except Exception:  # an arm that cannot say where it is now: no sample this time
            return None


def want_dots(camera: int) -> int:
    """The `WANTS` bit of camera c's dots."""
    return 1 << (8 + camera)


def _carries_all(topic: str) -> bool:
    return True


class SinkProcess:
    """The writer process `module` (`what`: its name in lines), fed with the rig's events (module
    docstring). `clock`: the rig's; `cameras`: its camera names; `config`: what the child needs
    beside the ring, the cameras and the time offset; `carries(topic)`: which session messages it
    takes (`post`)."""

    def __init__(
        self,
        what: str,
        module: str,
        config: dict[str, Any],
        *,
        clock: Clock,
        cameras: Sequence[str],
        slots: int = RING_SLOTS,
        vectors: bool = False,
        framed: bool = False,
        gated: bool = False,
        back_slots: int = 0,
        carries: Callable[[str], bool] = _carries_all,
        nice: int = WRITER_NICE,
        on_failure: Callable[[str], None] | None = None,
    ) -> None:
        self.what = what
        self.clock = clock
        self.wall = wall_time(clock)
        self.camera_names = list(cameras)
        self.vectors, self.framed, self.gated = vectors, framed, gated
        self.carries = carries
        self.markers_sent = 0
        self.dots_sent = [0] * len(self.camera_names)
        self._dots_bits = [want_dots(c) for c in range(len(self.camera_names))]
        self.arm_sent = 0
        self.too_large = 0
        self.unwanted = 0  # events not packed at all: the child wanted nothing then
        self.messages_dropped = 0
        self.messages_sent = 0
        self.arm: ArmSampler | None = None
        self._lock = threading.Lock()  # one event's records at a time
        self._unsubscribe: Unsubscribe | None = None
        self._source: MarkerSource | None = None
        self._outbox: queue.SimpleQueue[tuple[str, int, dict[str, Any]] | None] = queue.SimpleQueue()
        self._sender: threading.Thread | None = None
        self._send_faults = FaultLines(f"{what} sender")
        self.ring = FrameRing.create(slots, records.VECTOR_SLOT_BYTES if vectors else records.SLOT_BYTES)
        self.back = FrameRing.create(back_slots, records.BACK_SLOT_BYTES) if back_slots else None
        back = {} if self.back is None else {"back": [self.back.name, self.back.slots, self.back.slot_bytes]}
        try:
            self.process = WriterProcess(
                what,
                module,
                self.ring,
                {**config, **back, "cameras": self.camera_names, "offset_ns": self.wall.offset_ns, "nice": nice},
                on_failure=on_failure,
            )
        except BaseException:
            self.ring.close()
            if self.back is not None:
                self.back.close()
            raise

    # -- following a source (its thread, under its lock: never waits)

    def follow(self, source: MarkerSource, *, arm: ArmState | None = None) -> None:
        """Pack what `source` tells from now on (its calibration first); with `arm`, a session's arm too."""
        self.arm = ArmSampler(arm) if arm is not None else None
        with source.lock:  # between two polls: every event from now on, once
            if source.Ps is not None:
                self.publish_calibration(source.Ps)
            self._unsubscribe = source.subscribe(self.event)
        self._source = source

    def unfollow(self) -> None:
        unsubscribe, self._unsubscribe = self._unsubscribe, None
        if unsubscribe is not None and self._source is not None:
            with self._source.lock:
                unsubscribe()

    def wants(self) -> int:
        """What the child wants packed now (`WANTS`; everything for a sink that is not gated)."""
        return self.ring.figure(WANTS) if self.gated else WANT_ALL

    def event(self, event: RigEvent) -> None:
        """One event of the source, packed (module docstring; never raises into the rig)."""
        if isinstance(event, CalibrationChanged):
            self.publish_calibration(event.Ps)
            return
        wants = self.wants()
        if not wants:  # nothing packed; the frames still take their numbers
            self.unwanted += 1
            if isinstance(event, FramesProcessed | Flushed):
                with self._lock:
                    self.markers_sent += len(event.tracked)
                    if isinstance(event, FramesProcessed):
                        self.dots_sent[event.camera] += len(event.frames)
            return
        if isinstance(event, FramesProcessed):
            if not event.frames:
                return
            camera, ring = event.camera, self.ring
            with self._lock:
                if ring.closed:
                    return
                seq = self.dots_sent[camera]
                self.dots_sent[camera] = seq + len(event.frames)
                if wants & self._dots_bits[camera]:
                    for k, frame in enumerate(event.frames):
                        records.put_dots(ring, camera, seq + k, frame)
                for tracked in event.tracked:
                    self._markers(tracked, wants)
                if self.framed and wants & WANT_EVENTS:
                    records.put_end(ring, records.PROCESSED, camera)
                if self.arm is not None and wants & WANT_ARM:
                    self._arm(event.frames[-1].t)
                ring.wake()
        elif isinstance(event, Flushed):
            if not event.synced:
                return
            with self._lock:
                if self.ring.closed:
                    return
                for tracked in event.tracked:
                    self._markers(tracked, wants)
                if self.framed and wants & WANT_EVENTS:
                    records.put_end(self.ring, records.FLUSHED, now=event.now, synced=event.synced)
                self.ring.wake()
        elif self.framed and event.batch and wants & WANT_EVENTS:  # (the one event left: reports read)
            with self._lock:
                if self.ring.closed:
                    return
                try:
                    for t, data in event.batch:
                        records.put_report(self.ring, event.camera, t, data)
                except records.TooLarge as exc:
                    self._too_large(exc)
                records.put_end(self.ring, records.REPORTS, event.camera)
                self.ring.wake()

    def _dots(self, camera: int, frame: IRFrame, wants: int) -> int:
        seq = self.dots_sent[camera]
        self.dots_sent[camera] += 1
        if wants & self._dots_bits[camera]:
            records.put_dots(self.ring, camera, seq, frame)
        return seq

    def _markers(self, frame: TrackedFrame, wants: int) -> int:
        seq = self.markers_sent
        self.markers_sent += 1
        if wants & WANT_MARKERS:
            try:
                records.put_markers(self.ring, seq, frame, vectors=self.vectors)
            except records.TooLarge as exc:
                self._too_large(exc)
        return seq

    def _arm(self, t: float) -> None:
        assert self.arm is not None
        sample = self.arm.sample(t)
        if sample is not None:
            try:
                records.put_arm(self.ring, t, *sample)
                self.arm_sent += 1
            except records.TooLarge as exc:
                self._too_large(exc)

    def _too_large(self, exc: Exception) -> None:
        self.too_large += 1
        if self.too_large == 1:
            print(f"wiithrow: {self.what}: {exc}: such frames are not handed over", file=sys.stderr, flush=True)

    # -- the hand-over of one frame (what a caller that follows no source calls)

    def publish_markers(self, frame: TrackedFrame) -> int:
        """Hand one tracked frame over; its number."""
        with self._lock:
            if self.ring.closed:
                self.markers_sent += 1
                return self.markers_sent - 1
            seq = self._markers(frame, self.wants())
            self.ring.wake()
            return seq

    def publish_dots(self, camera: int, frame: IRFrame) -> int:
        """Hand one camera frame over; its number (per camera)."""
        with self._lock:
            if self.ring.closed:
                self.dots_sent[camera] += 1
                return self.dots_sent[camera] - 1
            seq = self._dots(camera, frame, self.wants())
            self.ring.wake()
            return seq

    def publish_calibration(self, Ps: NDArray[np.float64] | None, t: float | None = None) -> None:
        """Hand a calibration over (at `t`, the rig's clock; default: now), whatever the child wants."""
        if Ps is None:
            return
        t = self.clock.now() if t is None else t
        with self._lock:
            if self.ring.closed:
                return
            try:
                records.put_calibration(self.ring, Ps, t)
            except records.TooLarge as exc:
                self._too_large(exc)
            self.ring.wake()

    # -- a session's messages (its threads, then the sender's)

    def post(self, topic: str, stamp_ns: int, message: dict[str, Any]) -> None:
        """`message` of `topic` (stamped `stamp_ns`, Unix ns) for the child, if it carries the topic."""
        if not self.carries(topic):
            return
        with self._lock:
            if self._sender is None:
                self._sender = threading.Thread(
                    target=self._send_loop, name=f"wiithrow-{self.what}-sender", daemon=True
                )
                self._sender.start()
        if self._outbox.qsize() >= QUEUE_MESSAGES:
            self.messages_dropped += 1
        else:
            self._outbox.put((topic, stamp_ns, message))

    def _send_loop(self) -> None:
        while (item := self._outbox.get()) is not None:
            try:
                sent = self.process.send({"write": list(item)})
            except TypeError:  # not JSON: no sink could have written it either
                sent = False
            except Exception as exc:  # one line per kind; the sender goes on
                self._send_faults.report(exc, "the message is dropped, the sender goes on")
                sent = False
            if sent:
                self.messages_sent += 1
            else:  # or the child is gone
                self.messages_dropped += 1

    # -- what the child tells

    @property
    def failure(self) -> str | None:
        return self.process.failure

    @property
    def records_dropped(self) -> int:
        """Records the child lost: the ring came round before it read them."""
        return self.ring.dropped

    def figure(self, index: int) -> int:
        return self.ring.figure(index)

    def flush(self, timeout_s: float = 2.0) -> bool:
        """Wait until the child has read (and written) every record so far; whether it did in time."""
        return self.process.wait_until_read(timeout_s)

    def close(self) -> None:
        """Stop following, hand the last messages over, end the child after what it was handed
        (its stdin closes: `WriterProcess`); its last figures stay readable."""
        self.unfollow()
        sender, self._sender = self._sender, None
        if sender is not None:
            self._outbox.put(None)
            sender.join(timeout=SENDER_STOP_S)
            if sender.is_alive():  # blocked on a child that reads no more (stopped): end it, the write fails
                self.process.child.kill()
        self.flush(1.0)
        with self._lock:
            self.process.close()
        if self.back is not None:
            self.back.close()
