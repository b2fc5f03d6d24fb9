"""`FoxgloveServer`: foxglove-sdk's WebSocket server for the channels, the state a late client
needs, and who may reach it.

foxglove-sdk's server (`foxglove.start_server`) with its own `foxglove.Context`, so two servers in
one process never share channels, and a JSON channel per topic with the channels' schemas
(`registry`, `json_schemas`), advertised up front (`advertise`) so that a client sees them before
anything was logged; a message for a channel nobody subscribed to is not sent (`wanted` says so,
for a caller that may skip building it). The server advertises no client capability (no client
publish, services or parameters): a client can look, not act.

Late clients: the SDK sends a message only to the clients subscribed at that moment, so a state
written once (the cameras' frames at a calibration, the arm's URDF) would never reach a client
that connects later. The last message of every `latched` channel (`/tf`, `/tf_static`,
`/calibration`, `/robot_description`) is kept, subscribed or not, and logged again whenever a
client subscribes to its channel (`on_subscribe`, told to a thread of its own,
`wiithrow-foxglove-latched`, `RESEND_AFTER_S` later: the SDK takes a subscription in after it
calls its listener); the clients subscribed before get it twice, which a state allows.

Subprotocols: foxglove-sdk 0.30's server accepts the `foxglove.sdk.v1` WebSocket subprotocol
only, and has no option for another: a client that offers only `foxglove.websocket.v1` (the
`@foxglove/ws-protocol` package's client, Lichtblick before 1.22) is refused with HTTP 400, though
the two protocols are the same but for the name (docs/integrations/foxglove.md: which clients connect).

Who may reach it: this host's loopback (`LOOPBACK`) by default. Beyond loopback the dashboard's
rules (a token, a Host check) cannot be kept: foxglove-sdk 0.30.3's server sees a client as an id
only (`websocket.Client`: no request path, header or subprotocol reaches Python) and has no hook
that can refuse a connection; its TLS (`tls_cert`) encrypts but authenticates no client. So
`check_host` refuses any other host unless the caller accepts that risk (`insecure_network`, the
CLI's `--foxglove-insecure-network`, like Zenoh's `--insecure-network`); an SSH tunnel is the safe
way from another machine.

`FoxgloveProcessLive` is what `track --foxglove` (and, with a session, `demo`, `serve` and
`replay --dashboard`: `wiithrow.app.foxglove.session_process_live`) runs: the server and the
messages' encoding in a writer process (`foxglove_writer`), fed with the rig's events whole
(`SinkProcess`, `framed`), packed only while a client is subscribed to something (the child tells:
`WANTS`; calibrations always: the state a later client gets).

It imports neither the rig nor the session, so a writer process starts without them.
"""

from __future__ import annotations

import ipaddress
import sys
import threading
from collections.abc import Iterable, Sequence
from typing import TYPE_CHECKING, Any, cast

from wiithrow.app.channels import json_schemas
from wiithrow.app.channels.json_messages import encode
from wiithrow.app.channels.registry import channel_of
from wiithrow.app.channels.sink_process import SinkProcess
from wiithrow.app.errors import AppError

if TYPE_CHECKING:  # annotations only: the writer process imports this module for its server
    from wiithrow.app.rig.pipeline import TrackingPipeline
    from wiithrow.app.rig.source import MarkerSource

LOOPBACK = "127.0.0.1"
DEFAULT_PORT = 8765
#: How long after a client's subscription its channel's latched message is logged again (s): the
#: SDK calls its listener before the subscription takes effect; 50 ms is well within the 1 s a
#: newcomer may wait for the state, and long for the SDK's own thread on a loaded machine.
RESEND_AFTER_S = 0.05


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


def _listener(on_subscribe: Any) -> Any:
    """A foxglove `ServerListener` that counts the clients' subscriptions (`count`) and tells each
    subscription's topic to `on_subscribe`."""
    import foxglove

    class _Subscriptions(foxglove.ServerListener):
        def __init__(self) -> None:
            self.count = 0
            self._lock = threading.Lock()

        def on_subscribe(self, client: Any, channel: Any) -> None:
            with self._lock:
                self.count += 1
            on_subscribe(channel.topic)

        def on_unsubscribe(self, client: Any, channel: Any) -> None:  # also on a client's disconnect
            with self._lock:
                self.count = max(0, self.count - 1)

    return _Subscriptions()


class FoxgloveServer:
    """foxglove-sdk's server with its own context, a JSON channel per topic (`advertise`, or as it
    first comes), and the latched channels' last messages for late clients (module docstring)."""

    def __init__(self, port: int, host: str, insecure_network: bool) -> None:
        import foxglove

        check_host(host, insecure_network=insecure_network)
        self.host = host
        self.context = foxglove.Context()
        self.channels: dict[str, Any] = {}
        self.lock = threading.Lock()
        self.logged = 0  # messages logged to a channel a client subscribed to
        self.unread = 0  # messages not sent: nobody subscribed to their channel
        self.resent = 0  # latched messages logged again for a client that subscribed later
        self._latched: dict[str, tuple[int, bytes]] = {}  # topic -> (stamp_ns, its last message)
        self._to_resend: set[str] = set()
        self._resend = threading.Condition()  # its own lock: the SDK's thread never waits for `lock`
        self._stopping = False
        self.subscriptions = _listener(self._subscribed)
        try:
            self.server = foxglove.start_server(
                name="wiithrow", host=host, port=port, context=self.context, server_listener=self.subscriptions
            )
        except Exception as exc:  # the port is taken, most often
            raise AppError(f"--foxglove: cannot serve on {host}:{port}: {exc}") from None
        self._resender = threading.Thread(target=self._resend_loop, name="wiithrow-foxglove-latched", daemon=True)
        self._resender.start()

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
            spec = channel_of(topic)
            if spec is None:
                raise ValueError(f"no channel {topic!r}")
            data = json_schemas.schema_bytes(spec.schema)
            schema = foxglove.Schema(name=spec.schema, encoding="jsonschema", data=data)
            channel = foxglove.Channel(topic, schema=schema, message_encoding="json", context=self.context)
            self.channels[topic] = channel
        return channel

    def wanted(self, topic: str) -> bool:
        """Whether a message of `topic` would reach a client now (a latched one is kept regardless)."""
        with self.lock:
            channel = self.channels.get(topic)
        return channel is None or bool(channel.has_sinks())

    def write(self, topic: str, stamp_ns: int, message: dict[str, Any]) -> None:
        """Log `message` (its log time `stamp_ns`, Unix ns) on `topic` to the clients subscribed to it."""
        spec = channel_of(topic)
        data = None
        with self.lock:
            channel = self._channel(topic)
            if spec is not None and spec.latched:
                data = encode(message)
                self._latched[topic] = (stamp_ns, data)
            if not channel.has_sinks():
                self.unread += 1
                return
            self.logged += 1
        try:
            channel.log(data if data is not None else encode(message), log_time=stamp_ns)
        except Exception:  # the server stopped under us: nothing to show any more, the rig goes on
            pass

    def _subscribed(self, topic: str) -> None:
        """A client subscribed to `topic` (the SDK's thread): its latched message goes again, soon."""
        spec = channel_of(topic)
        if spec is not None and spec.latched:
            with self._resend:
                self._to_resend.add(topic)
                self._resend.notify()

    def _resend_loop(self) -> None:
        while True:
            with self._resend:
                self._resend.wait_for(lambda: self._to_resend or self._stopping)
                if self._resend.wait_for(lambda: self._stopping, timeout=RESEND_AFTER_S):
                    return
                topics, self._to_resend = self._to_resend, set()
            with self.lock:
                due = [(self.channels[t], *self._latched[t]) for t in topics if t in self._latched]
                self.resent += len(due)
            for channel, stamp_ns, data in due:
                try:
                    channel.log(data, log_time=stamp_ns)
                except Exception:  # the server stopped under us
                    return

    def stop(self) -> None:
        with self._resend:
            self._stopping = True
            self._resend.notify_all()
        self._resender.join(timeout=2.0)
        self.server.stop()


#: The child's figures in the ring's header (`FrameRing.report`; `WANTS` is the sink process's).
PORT, LOGGED = 3, 5


class FoxgloveProcessLive(SinkProcess):
    """A rig's channels, live, on `host`:`port` (0: a free one), served by a writer process, until
    `close()` (module docstring; `host` beyond loopback only with `insecure_network`); `session`:
    a session's channels too, its arm's joints named `joint_names`."""

    def __init__(
        self,
        rig: MarkerSource | TrackingPipeline,
        *,
        port: int = DEFAULT_PORT,
        frame_id: str = "link1",
        host: str = LOOPBACK,
        insecure_network: bool = False,
        command: str = "foxglove",
        session: bool = False,
        joint_names: Sequence[str] = (),
        follow: bool = True,
    ) -> None:
        check_host(host, insecure_network=insecure_network)
        self.host = host

        def tell(failure: str) -> None:
            print(f"wiithrow {command}: {failure}; tracking goes on without Foxglove", file=sys.stderr, flush=True)

        config = {
            "port": port,
            "host": host,
            "frame_id": frame_id,
            "session": session,
            "joint_names": list(joint_names),
        }
        super().__init__(
            "Foxglove",
            "wiithrow.app.channels.foxglove_writer",
            config,
            clock=rig.clock,
            cameras=rig.camera_names,
            framed=True,
            gated=True,
            on_failure=tell,
        )
        self.port = self.figure(PORT)
        if follow:
            self.follow(cast("MarkerSource", rig))  # (a pipeline has what following takes: its lock, subscribe, Ps)

    def url(self) -> str:
        host = f"[{self.host}]" if ":" in self.host else self.host
        return f"ws://{host}:{self.port}"

    def logged(self) -> int:
        """Messages logged so far, to a client subscribed to their channel (the child's count)."""
        return self.figure(LOGGED)

    def dropped(self) -> int:
        """Records the child lost: the ring came round before it read them."""
        return self.records_dropped

    def unwatched(self) -> int:
        """Rig events skipped: no client was subscribed to anything."""
        return self.unwanted
