"""`FoxgloveLive`: what a recording would write, served live to Foxglove instead.

foxglove-sdk's WebSocket server (`foxglove.start_server`, subprotocol `foxglove.sdk.v1`) on this
host's loopback (`LOOPBACK`) by default, with its own `foxglove.Context`, so two servers in one
process never share channels. Beyond loopback the dashboard's rules (a token, a Host check) cannot
be kept: foxglove-sdk 0.30.3's server sees a client as an id only (`websocket.Client`: no request
path, header or subprotocol reaches Python) and has no hook that can refuse a connection; its TLS
(`tls_cert`) encrypts but authenticates no client. So `check_host` refuses any other host unless
the caller accepts that risk (`insecure_network`, the CLI's `--foxglove-insecure-network`, like
Zenoh's `--insecure-network`); an SSH tunnel is the safe way from another machine. The server
advertises no client capability (no client publish, services or parameters): a client can look,
not act. The channels are the recording's: the same topics, the same JSON
schemas (`wiithrow.app.recording.channels`: `/markers/scene` as `foxglove.SceneUpdate` for the 3D
panel, `/tf` as `foxglove.FrameTransforms`, each camera's dots, the markers, the steps and raw
reports, and for a session the arm's joints, trajectories and throws), and the same messages:
`FoxgloveLive` *is* a `Recorder` (and `FoxgloveSessionLive` a `SessionRecorder`) whose `_write`
logs to a Foxglove channel instead of an MCAP chunk, each message with the log time the
recording would give it (the rig's clock, ns). Unlike a recording, it starts from the rig's
state as it is (no restart: track ids go on).

Off the tracking thread (issue 24: `bench tracking` unchanged with `--foxglove`): the rig's
events (called on the thread that polls it) are only queued, `_Relay`, and a thread of the
server's turns them into messages; a queue `QUEUE_EVENTS` long that is full drops the event and
counts it (`dropped()`), never blocks the rig. While no client is subscribed to any channel
(`_Subscriptions`, the server's listener) an event is not even queued: nothing would be sent
(calibrations excepted: rare). The rig's channels (and a session's) are advertised from the
start, so a client sees them before anything was logged; a message for a channel nobody subscribed to is not
encoded.
"""

from __future__ import annotations

import ipaddress
import queue
import threading
from collections.abc import Callable, Iterable
from typing import Any, cast

from wiithrow.app.errors import AppError
from wiithrow.app.recording import channels as ch
from wiithrow.app.recording.recorder import Recorder, _encode, _ns
from wiithrow.app.recording.session import SessionRecorder
from wiithrow.app.rig.events import CalibrationChanged, RigEvent
from wiithrow.app.rig.pipeline import TrackingPipeline
from wiithrow.app.rig.source import MarkerSource

LOOPBACK = "127.0.0.1"
DEFAULT_PORT = 8765
#: Rig events the server's thread may be behind (a 2-camera rig makes ~400 a second at 100 Hz).
QUEUE_EVENTS = 1000


def is_loopback_host(host: str) -> bool:
    """True for an address only this machine reaches (127.0.0.0/8, ::1, `localhost`)."""
    if host.lower() == "localhost":
        return True
    try:
        return ipaddress.ip_address(host).is_loopback
    except ValueError:  # a host name: where it resolves is another host's business
        return False


def check_host(host: str, *, insecure_network: bool) -> None:
    """Refuse a host beyond loopback unless `insecure_network`: the server cannot check a client."""
    if not is_loopback_host(host) and not insecure_network:
        raise AppError(
            f"--foxglove-host {host}: foxglove-sdk's server cannot check a token or a client's Host, so whoever "
            "reaches the port would see the rig live; from another machine use an SSH tunnel (ssh -L "
            "PORT:127.0.0.1:PORT this-host), or accept that on a trusted network with --foxglove-insecure-network"
        )


def _subscriptions() -> Any:
    """A foxglove `ServerListener` that counts the clients' subscriptions (`count`)."""
    import foxglove

    class _Subscriptions(foxglove.ServerListener):
        def __init__(self) -> None:
            self.count = 0
            self._lock = threading.Lock()

        def on_subscribe(self, client: Any, channel: Any) -> None:
            with self._lock:
                self.count += 1

        def on_unsubscribe(self, client: Any, channel: Any) -> None:  # also on a client's disconnect
            with self._lock:
                self.count = max(0, self.count - 1)

    return _Subscriptions()


class FoxgloveServer:
    """foxglove-sdk's server with its own context, and a JSON channel per topic (`advertise`, or
    as it first comes)."""

    def __init__(self, port: int, host: str, insecure_network: bool) -> None:
        import foxglove

        check_host(host, insecure_network=insecure_network)
        self.host = host
        self.context = foxglove.Context()
        self.channels: dict[str, Any] = {}
        self.lock = threading.Lock()
        self.logged = 0  # messages logged to a channel a client subscribed to
        self.unread = 0  # messages not encoded: nobody subscribed to their channel
        self.subscriptions = _subscriptions()
        try:
            self.server = foxglove.start_server(
                name="wiithrow", host=host, port=port, context=self.context, server_listener=self.subscriptions
            )
        except Exception as exc:  # the port is taken, most often
            raise AppError(f"--foxglove: cannot serve on {host}:{port}: {exc}") from None

    @property
    def port(self) -> int:
        return int(self.server.port)

    def url(self) -> str:
        host = f"[{self.host}]" if ":" in self.host else self.host
        return f"ws://{host}:{self.port}"

    def watched(self) -> bool:
        """Whether a client is subscribed to some channel."""
        return bool(self.subscriptions.count)

    def advertise(self, topics: Iterable[str]) -> None:
        with self.lock:
            for topic in topics:
                self._channel(topic)

    def _channel(self, topic: str) -> Any:
        import foxglove

        channel = self.channels.get(topic)
        if channel is None:
            name = ch.schema_of(topic)
            schema = foxglove.Schema(name=name, encoding="jsonschema", data=ch.schema_bytes(name))
            channel = foxglove.Channel(topic, schema=schema, message_encoding="json", context=self.context)
            self.channels[topic] = channel
        return channel

    def write(self, topic: str, t: float, message: dict[str, Any]) -> None:
        with self.lock:
            channel = self._channel(topic)
            if not channel.has_sinks():
                self.unread += 1
                return
            self.logged += 1
        try:
            channel.log(_encode(message), log_time=_ns(t))
        except Exception:  # the server stopped under us: nothing to show any more, the rig goes on
            pass

    def stop(self) -> None:
        self.server.stop()


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
            self.handle(event)  # a Recorder's handler never raises

    def stop(self) -> None:
        """End the thread after what is queued."""
        thread, self._thread = self._thread, None
        if thread is not None:
            self._queue.put(None)
            thread.join(timeout=2.0)


def rig_topics(cameras: int) -> list[str]:
    """The channels a rig's events write to."""
    per_camera = [topic for c in range(cameras) for topic in (ch.reports_topic(c), ch.dots_topic(c))]
    return [*per_camera, ch.STEPS, ch.MARKERS, ch.MARKERS_SCENE, ch.CALIBRATION, ch.TF]


#: The channels a session adds to its rig's (`SessionRecorder`), advertised from the start: a
#: channel first advertised with its first message would lose that message (no client could have
#: subscribed yet: the first throw never reached Foxglove).
SESSION_TOPICS = (ch.JOINTS, ch.TRAJECTORY, ch.THROWS)


def _follow(
    recorder: Recorder, rig: TrackingPipeline | MarkerSource, server: FoxgloveServer, *, thread: bool
) -> _Relay:
    """`recorder` listens to `rig` from now on, as it is (the calibration first), through a `_Relay`."""
    server.advertise(rig_topics(len(rig.camera_names)))
    relay = _Relay(recorder._event_of_rig, server.watched, thread=thread)
    recorder._rig = cast(TrackingPipeline, rig)  # what _detach unsubscribes from
    with rig.lock:
        if rig.Ps is not None:
            recorder.calibrated(rig.Ps)
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

    def _write(self, topic: str, t: float, message: dict[str, Any]) -> None:
        self._server.write(topic, t, message)

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
        self._server.advertise(SESSION_TOPICS)
        self._throws_seen = len(session.history)
        session.subscribe(self._event)
        self._relay = _follow(self, session.world.rig, self._server, thread=True)

    def url(self) -> str:
        return self._server.url()

    def start(self, rig: TrackingPipeline) -> None:
        raise TypeError("FoxgloveSessionLive follows its session from its construction")

    def _write(self, topic: str, t: float, message: dict[str, Any]) -> None:
        self._server.write(topic, t, message)

    def close(self) -> None:
        self.session.unsubscribe(self._event)
        self._detach()
        self._relay.stop()
        self._server.stop()
