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
"""

from __future__ import annotations

import ipaddress
import threading
from typing import Any, cast

from wiithrow.app.errors import AppError
from wiithrow.app.recording import channels as ch
from wiithrow.app.recording.recorder import Recorder, _encode, _ns
from wiithrow.app.recording.session import SessionRecorder
from wiithrow.app.rig.pipeline import TrackingPipeline
from wiithrow.app.rig.source import MarkerSource

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


class _Server:
    """foxglove-sdk's server with its own context, and a JSON channel per topic as it first comes."""

    def __init__(self, port: int, host: str, insecure_network: bool) -> None:
        import foxglove

        check_host(host, insecure_network=insecure_network)
        self.host = host
        self.context = foxglove.Context()
        self.channels: dict[str, Any] = {}
        self.lock = threading.Lock()
        self.logged = 0  # messages logged to a channel (sent to the clients subscribed to it)
        try:
            self.server = foxglove.start_server(name="wiithrow", host=host, port=port, context=self.context)
        except Exception as exc:  # the port is taken, most often
            raise AppError(f"--foxglove: cannot serve on {host}:{port}: {exc}") from None

    @property
    def port(self) -> int:
        return int(self.server.port)

    def url(self) -> str:
        host = f"[{self.host}]" if ":" in self.host else self.host
        return f"ws://{host}:{self.port}"

    def write(self, topic: str, t: float, message: dict[str, Any]) -> None:
        import foxglove

        with self.lock:
            channel = self.channels.get(topic)
            if channel is None:
                name = ch.schema_of(topic)
                schema = foxglove.Schema(name=name, encoding="jsonschema", data=ch.schema_bytes(name))
                channel = foxglove.Channel(topic, schema=schema, message_encoding="json", context=self.context)
                self.channels[topic] = channel
            self.logged += 1
        try:
            channel.log(_encode(message), log_time=_ns(t))
        except Exception:  # the server stopped under us: nothing to show any more, the rig goes on
            pass

    def stop(self) -> None:
        self.server.stop()


def _follow(recorder: Recorder, rig: TrackingPipeline | MarkerSource) -> None:
    """`recorder` listens to `rig` from now on, as it is (the calibration first)."""
    recorder._rig = cast(TrackingPipeline, rig)  # what _detach unsubscribes from
    with rig.lock:
        if rig.Ps is not None:
            recorder.calibrated(rig.Ps)
        recorder._unsubscribe = rig.subscribe(recorder._event_of_rig)


class FoxgloveLive(Recorder):
    """A rig's channels, live, on `host`:`port` (0: a free one) until `close()` (`host` beyond
    loopback only with `insecure_network`: `check_host`). (A `Recorder` without a file: `path` is
    never opened.)"""

    def __init__(
        self,
        rig: TrackingPipeline | MarkerSource,
        *,
        port: int = DEFAULT_PORT,
        frame_id: str = "link1",
        host: str = LOOPBACK,
        insecure_network: bool = False,
    ) -> None:
        super().__init__("unused.mcap", rig.clock, frame_id=frame_id)
        self._server = _Server(port, host, insecure_network)
        self.port = self._server.port
        _follow(self, rig)

    def url(self) -> str:
        return self._server.url()

    def logged(self) -> int:
        """Messages logged so far (on every channel)."""
        return self._server.logged

    def start(self, rig: TrackingPipeline) -> None:
        raise TypeError("FoxgloveLive follows its rig from its construction")

    def _write(self, topic: str, t: float, message: dict[str, Any]) -> None:
        self._server.write(topic, t, message)

    def close(self) -> None:
        self._detach()
        self._server.stop()


class FoxgloveSessionLive(SessionRecorder):
    """A session's channels (its rig, arm and throws), live, on `host`:`port` until `close()`."""

    def __init__(
        self, session: Any, *, port: int = DEFAULT_PORT, host: str = LOOPBACK, insecure_network: bool = False
    ) -> None:
        super().__init__(session, "unused.mcap")
        self._server = _Server(port, host, insecure_network)
        self.port = self._server.port
        self._throws_seen = len(session.history)
        session.subscribe(self._event)
        _follow(self, session.world.rig)

    def url(self) -> str:
        return self._server.url()

    def start(self, rig: TrackingPipeline) -> None:
        raise TypeError("FoxgloveSessionLive follows its session from its construction")

    def _write(self, topic: str, t: float, message: dict[str, Any]) -> None:
        self._server.write(topic, t, message)

    def close(self) -> None:
        self.session.unsubscribe(self._event)
        self._detach()
        self._server.stop()
