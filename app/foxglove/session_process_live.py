"""`FoxgloveSessionProcessLive`: Foxglove live for a session, its server and encoding in a writer process.

What `demo`, `serve` and `replay --dashboard` run with `--foxglove`. In-process
(`FoxgloveSessionLive`), the session's channels are encoded on threads of the process that
tracks and throws; here they are handed to the writer process `FoxgloveProcessLive` starts
(`writer_main`, `session` on), which writes them with the recording's code, so that Foxglove sees
the channels, schemas and messages a `SessionRecorder`'s file has:

- the rig's events: packed into the `FrameRing` as `FoxgloveProcessLive` packs them;
- the arm, sampled where the recorder samples it (`SessionRecorder.processed`: on the rig's
  thread, once a camera's frames were processed, at most every `JOINTS_PERIOD_S` of the world's
  clock; about 10 us: `state()` and the base -> link1 placement): one `ARM` record
  (`frame_records.put_arm`), which the child writes as `/arm/joints` and `/tf` (base -> link1 and
  the cameras in link1, from the last calibration it was handed: the rig's `Ps`, as the recorder
  reads them); skipped, like the rig's events, while no client is subscribed;
- the session's events (a previewed throw's trajectory, each throw and its landing): the
  recorder's own `SessionRecorder._event` builds the messages on the thread that tells the event
  (the session's), and a sender thread of this process hands each to the child as one JSON line
  on its stdin (`WriterProcess.send`, which may block: never on the session's thread). At most
  `QUEUE_MESSAGES` wait; one more is dropped and counted (`messages_dropped`).

A child that ends is one line on stderr (`FoxgloveProcessLive`); the rig and the session go on:
the ring overwrites, and a message to a child that is gone is dropped.
"""

from __future__ import annotations

import queue
import threading
from typing import Any

from wiithrow.app.foxglove.process_live import WATCHED, FoxgloveProcessLive
from wiithrow.app.foxglove.server import DEFAULT_PORT, LOOPBACK
from wiithrow.app.network import frame_records as records
from wiithrow.app.recording.session import JOINTS_PERIOD_S, SessionRecorder
from wiithrow.app.rig.events import FramesProcessed
from wiithrow.app.session import Session
from wiithrow.fault_lines import FaultLines

#: Session messages (trajectories, throws) the sender thread may be behind.
QUEUE_MESSAGES = 100
SENDER_STOP_S = 2.0


class _SessionMessages(SessionRecorder):
    """The recorder's messages of a session's events (never started: no file), each to `send`."""

    def __init__(self, session: Session, send: Any) -> None:
        super().__init__(session, "unused.mcap")
        self.send = send
        self._throws_seen = len(session.history)

    def _write(self, topic: str, t: float, message: dict[str, Any]) -> None:
        self.send(topic, t, message)


class FoxgloveSessionProcessLive(FoxgloveProcessLive):
    """A session's channels (its rig, arm and throws), live, on `host`:`port` (0: a free one),
    served by a writer process, until `close()` (module docstring; `host` beyond loopback only
    with `insecure_network`)."""

    def __init__(
        self,
        session: Session,
        *,
        port: int = DEFAULT_PORT,
        host: str = LOOPBACK,
        insecure_network: bool = False,
        command: str = "foxglove",
    ) -> None:
        self.session = session
        self.world = session.world
        self.messages_dropped = 0
        self._last_joints = -1e9
        self._outbox: queue.SimpleQueue[tuple[str, float, dict[str, Any]] | None] = queue.SimpleQueue()
        self._sender: threading.Thread | None = None
        self._send_faults = FaultLines("Foxglove sender")
        # the rig's events flow from the end of this (the arm's samples with them: the attributes above)
        super().__init__(
            session.world.rig,
            port=port,
            frame_id="link1",
            host=host,
            insecure_network=insecure_network,
            command=command,
            session=True,
        )
        self._sender = threading.Thread(target=self._send_loop, name="wiithrow-foxglove-sender", daemon=True)
        self._sender.start()
        self._messages = _SessionMessages(session, self._post)
        session.subscribe(self._messages._event)

    # -- the arm (the rig's thread)

    def _processed(self, event: FramesProcessed) -> None:
        """`SessionRecorder.processed`'s arm sample, as a record (under the lock; never raises)."""
        if not event.frames or event.frames[-1].t - self._last_joints < JOINTS_PERIOD_S:
            return
        if not self.ring.figure(WATCHED):
            return
        t = event.frames[-1].t
        self._last_joints = t
        try:
            state = self.world.arm.state()
            T = self.world.arm_model.frame_placement(state.q, "link1")
            records.put_arm(self.ring, t, state.q, state.dq, T)
        except Exception:  # an arm that cannot say where it is now (or too many joints): no sample this time
            return

    # -- the session's messages (the session's threads, then the sender's)

    def _post(self, topic: str, t: float, message: dict[str, Any]) -> None:
        if self._outbox.qsize() >= QUEUE_MESSAGES:
            self.messages_dropped += 1
        else:
            self._outbox.put((topic, t, message))

    def _send_loop(self) -> None:
        while (item := self._outbox.get()) is not None:
            topic, t, message = item
            try:
                sent = self.process.send({"write": [topic, t, message]})
            except TypeError:  # not JSON: the recorder could not have written it either
                sent = False
            except Exception as exc:  # one line per kind; the sender goes on
                self._send_faults.report(exc, "the message is dropped, the sender goes on")
                sent = False
            if not sent:  # or the child is gone
                self.messages_dropped += 1

    def close(self) -> None:
        self.session.unsubscribe(self._messages._event)
        sender, self._sender = self._sender, None
        if sender is not None:
            self._outbox.put(None)
            sender.join(timeout=SENDER_STOP_S)
            if sender.is_alive():  # blocked on a child that reads no more (stopped): end it, the write fails
                self.process.child.kill()
        super().close()
