"""`FoxgloveLive`: what a recording would write, served live to Foxglove instead.

Served by a `FoxgloveServer` (`wiithrow.app.channels.foxglove_sink`: foxglove-sdk's WebSocket
server on this host's loopback by default, beyond it only with `insecure_network`; a client can
look, not act; a late client gets the latched state). The channels are the recording's: the same
topics, the same JSON schemas (`wiithrow.app.channels.registry`: `/markers/scene` as
`foxglove.SceneUpdate` for the 3D panel, `/tf` and `/tf_static` as `foxglove.FrameTransforms`,
each camera's dots, the markers, the steps and raw reports, and for a session the arm's joints,
URDF, trajectories and throws), and the same messages: `FoxgloveLive` *is* a `Recorder` (and
`FoxgloveSessionLive` a `SessionRecorder`) whose `_write` logs to a Foxglove channel instead of an
MCAP chunk, each message with the log time the recording would give it (its Unix time). Unlike a
recording, it starts from the rig's state as it is (no restart: track ids go on). (What the CLI
runs is `FoxgloveProcessLive`, in a writer process; this is the in-process reference the tests
compare it with.)

Off the tracking thread: the rig's
events (called on the thread that polls it) are only queued, `_Relay`, and a thread of the
server's turns them into messages; a queue `QUEUE_EVENTS` long that is full drops the event and
counts it (`dropped()`), never blocks the rig. While no client is subscribed to any channel
(the server's subscriptions) an event is not even queued: nothing would be sent
(calibrations excepted: rare). The rig's channels (and a session's) are advertised from the
start, so a client sees them before anything was logged.
"""

from __future__ import annotations

import queue
import threading
from collections.abc import Callable
from typing import Any, cast

from wiithrow.app.channels import registry as r
from wiithrow.app.channels.foxglove_sink import DEFAULT_PORT, LOOPBACK, FoxgloveServer
from wiithrow.app.recording.recorder import Recorder
from wiithrow.app.recording.session import SessionRecorder
from wiithrow.app.rig.events import CalibrationChanged, RigEvent
from wiithrow.app.rig.pipeline import TrackingPipeline
from wiithrow.app.rig.source import MarkerSource
from wiithrow.fault_lines import FaultLines

#: Rig events the server's thread may be behind (a 2-camera rig makes ~400 a second at 100 Hz).
QUEUE_EVENTS = 1000


class _Relay:
    """The rig's events, from the thread that polls it to `handle` on a thread of its own
    (`thread=False`: at once, on the caller's), skipped while `watched()` says nobody looks; at
    most `QUEUE_EVENTS` waiting, one more is dropped and counted."""

    def __init__(self, handle: Callable[[RigEvent], None], watched: Callable[[], bool], *, thread: bool) -> None:
        self.handle = handle
        self.watched = watched
        self.dropped = 0
        self.unwatched = 0
        self._queue: queue.SimpleQueue[RigEvent | None] = queue.SimpleQueue()
        self._faults = FaultLines("Foxglove relay")
        self._thread: threading.Thread | None = None
        if thread:
            self._thread = threading.Thread(target=self._run, name="wiithrow-foxglove", daemon=True)
            self._thread.start()

    def put(self, event: RigEvent) -> None:
        if not self.watched() and not isinstance(event, CalibrationChanged):
            self.unwatched += 1
        elif self._thread is None:
            self.handle(event)
        elif self._queue.qsize() >= QUEUE_EVENTS:
            self.dropped += 1
        else:
            self._queue.put(event)

    def _run(self) -> None:
        while (event := self._queue.get()) is not None:
            with self._faults.guard("the relay goes on"):  # (a Recorder's handler is not meant to raise)
                self.handle(event)

    def stop(self) -> None:
        """End the thread after what is queued."""
        thread, self._thread = self._thread, None
        if thread is not None:
            self._queue.put(None)
            thread.join(timeout=2.0)


def _follow(
    recorder: Recorder, rig: TrackingPipeline | MarkerSource, server: FoxgloveServer, *, thread: bool
) -> _Relay:
    """`recorder` listens to `rig` from now on, as it is (the calibration first), through a `_Relay`."""
    server.advertise(r.topics(r.RIG_CHANNELS, len(rig.camera_names)))
    recorder.rig_messages.wanted = server.wanted
    relay = _Relay(recorder._event_of_rig, server.watched, thread=thread)
    recorder._rig = cast(TrackingPipeline, rig)  # what _detach unsubscribes from
    with rig.lock:
        if rig.Ps is not None:
            recorder.rig_messages.calibrated(rig.Ps, rig.clock.now())
        recorder._unsubscribe = rig.subscribe(relay.put)
    return relay


class FoxgloveLive(Recorder):
    """A rig's channels, live, on `host`:`port` (0: a free one) until `close()` (`host` beyond
    loopback only with `insecure_network`: `check_host`), its events turned into messages by a
    thread of its own (`thread=False`: on the rig's). (A `Recorder` without a file: `path` is
    never opened.)"""

    def __init__(
        self,
        rig: TrackingPipeline | MarkerSource,
        *,
        port: int = DEFAULT_PORT,
        frame_id: str = "link1",
        host: str = LOOPBACK,
        insecure_network: bool = False,
        thread: bool = True,
    ) -> None:
        super().__init__("unused.mcap", rig.clock, frame_id=frame_id)
        self._server = FoxgloveServer(port, host, insecure_network)
        self.port = self._server.port
        self._relay = _follow(self, rig, self._server, thread=thread)

    def url(self) -> str:
        return self._server.url()

    def logged(self) -> int:
        """Messages logged so far (on every channel), to a client subscribed to it."""
        return self._server.logged

    def dropped(self) -> int:
        """Rig events dropped: the server's thread was `QUEUE_EVENTS` behind."""
        return self._relay.dropped

    def unwatched(self) -> int:
        """Rig events skipped: no client was subscribed to anything."""
        return self._relay.unwatched

    def start(self, rig: TrackingPipeline) -> None:
        raise TypeError("FoxgloveLive follows its rig from its construction")

    def _write(self, topic: str, stamp_ns: int, message: dict[str, Any]) -> None:
        self._server.write(topic, stamp_ns, message)

    def close(self) -> None:
        self._detach()
        self._relay.stop()
        self._server.stop()


class FoxgloveSessionLive(SessionRecorder):
    """A session's channels (its rig, arm and throws), live, on `host`:`port` until `close()`, in
    this process. (Not what the CLI runs: `FoxgloveSessionProcessLive`. Its arm is sampled on the
    relay's thread, later than the frame whose time stamps the sample, so its joints are not the
    recording's.)"""

    def __init__(
        self, session: Any, *, port: int = DEFAULT_PORT, host: str = LOOPBACK, insecure_network: bool = False
    ) -> None:
        super().__init__(session, "unused.mcap")
        self._server = FoxgloveServer(port, host, insecure_network)
        self.port = self._server.port
        self._server.advertise(r.topics(r.SESSION_CHANNELS, len(session.world.rig.camera_names)))
        self.feed.start()
        self._relay = _follow(self, session.world.rig, self._server, thread=True)

    def url(self) -> str:
        return self._server.url()

    def start(self, rig: TrackingPipeline) -> None:
        raise TypeError("FoxgloveSessionLive follows its session from its construction")

    def _write(self, topic: str, stamp_ns: int, message: dict[str, Any]) -> None:
        self._server.write(topic, stamp_ns, message)

    def close(self) -> None:
        self.feed.stop()
        self._detach()
        self._relay.stop()
        self._server.stop()
