"""`FoxgloveServer`: foxglove-sdk's WebSocket server for wiithrow's channels, and who may reach it.

foxglove-sdk's server (`foxglove.start_server`, subprotocol `foxglove.sdk.v1`) with its own
`foxglove.Context`, so two servers in one process never share channels, and a JSON channel per
topic with the recording's schemas (`wiithrow.app.recording.channels`), advertised up front
(`rig_topics`, `SESSION_TOPICS`) so that a client sees them before anything was logged; a
message for a channel nobody subscribed to is not encoded. The server advertises no client
capability (no client publish, services or parameters): a client can look, not act.

It listens on this host's loopback (`LOOPBACK`) by default. Beyond loopback the dashboard's rules
(a token, a Host check) cannot be kept: foxglove-sdk 0.30.3's server sees a client as an id only
(`websocket.Client`: no request path, header or subprotocol reaches Python) and has no hook that
can refuse a connection; its TLS (`tls_cert`) encrypts but authenticates no client. So
`check_host` refuses any other host unless the caller accepts that risk (`insecure_network`, the
CLI's `--foxglove-insecure-network`, like Zenoh's `--insecure-network`); an SSH tunnel is the safe
way from another machine.

Both `FoxgloveLive` (in this process) and the writer process (`writer_main`) serve through it;
this module imports neither the rig nor the session, so a writer process starts without them.
"""

from __future__ import annotations

import ipaddress
import threading
from collections.abc import Iterable
from typing import Any

from wiithrow.app.errors import AppError
from wiithrow.app.recording import channels as ch
from wiithrow.app.recording.recorder import _encode, _ns

LOOPBACK = "127.0.0.1"
DEFAULT_PORT = 8765


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


def rig_topics(cameras: int) -> list[str]:
    """The channels a rig's events write to."""
    per_camera = [topic for c in range(cameras) for topic in (ch.reports_topic(c), ch.dots_topic(c))]
    return [*per_camera, ch.STEPS, ch.MARKERS, ch.MARKERS_SCENE, ch.CALIBRATION, ch.TF]


#: The channels a session adds to its rig's (`SessionRecorder`), advertised from the start: a
#: channel first advertised with its first message would lose that message (no client could have
#: subscribed yet: the first throw never reached Foxglove).
SESSION_TOPICS = (ch.JOINTS, ch.TRAJECTORY, ch.THROWS)
