"""The access checks installed in viser's websocket server: the one place that knows how viser 1.1
accepts a connection.

viser has no hook for checking who connects (docs/dashboard-notes.md). It serves its page and its
websocket on one port through `websockets.asyncio.server.serve(ws_handler, host, port,
process_request=viser_http_server, ...)`, called in its server thread while `ViserServer()`
starts. `start_viser` constructs the `ViserServer` while `websockets.asyncio.server.serve` is
replaced by a function that wraps that call's `process_request` with `Gatekeeper` and delegates;
the replacement is in place only during the construction, under a lock, and wraps only calls for
our host that pass a `process_request`. A viser that starts its server differently wraps nothing:
`start_viser` then stops it and raises `UnsupportedViser`, so the dashboard never serves unchecked
(tests/web/test_access.py checks each of these facts against the installed viser).

For every request, `Gatekeeper`'s `process_request`
* refuses with 403 (and logs) what `AccessPolicy.check_request` refuses, before viser sees it;
* for a websocket it lets in: records the connection's role in a context variable (websockets runs
  the handshake and viser's handler in one task, and viser's tasks for the connection inherit its
  context, so an `on_client_connect` coroutine reads the new client's role with `current_role()`),
  and wraps the connection's `recv`, through which viser's consumer reads every client message,
  with `admit_message`: a message the role may not send is dropped and logged, never reaching
  viser;
* for the page: forbids framing by other sites and Referers (`PAGE_HEADERS`), and with a valid
  `?token=` adds the operator cookie to viser's response.
"""

from __future__ import annotations

import contextvars
import http
import threading
from collections.abc import Callable
from typing import Any

import viser
import websockets.asyncio.server
from websockets.asyncio.server import ServerConnection
from websockets.http11 import Request, Response

from wiithrow.app.errors import AppError
from wiithrow.web.access import AccessPolicy, RefusalLog, Role, admit_message, without_query

#: The viser versions whose handshake this module wraps (pyproject.toml pins the same).
SUPPORTED_VISER = ((1, 1),)
#: Added to every page served: no other site may frame the controls (clickjacking), and the link's
#: token never leaves as a Referer.
PAGE_HEADERS = {
    "X-Frame-Options": "DENY",
    "Content-Security-Policy": "frame-ancestors 'none'",
    "Referrer-Policy": "no-referrer",
}
#: Request headers the rules read; each may come once.
_CHECKED_HEADERS = ("Host", "Origin", "Cookie", "Authorization")

_ROLE: contextvars.ContextVar[Role | None] = contextvars.ContextVar("wiithrow_role", default=None)
_PATCH_LOCK = threading.Lock()

ProcessRequest = Callable[[ServerConnection, Request], Any]


class UnsupportedViser(AppError):
    """The installed viser does not start its server the way `start_viser` wraps (the command line
    says so in one line: the install, not the code, is to fix)."""


def current_role() -> Role | None:
    """The role of the connection whose viser task runs now (None outside one)."""
    return _ROLE.get()


def viser_version() -> tuple[int, int]:
    major, minor = viser.__version__.split(".")[:2]
    return int(major), int(minor)


def check_viser_supported() -> None:
    if viser_version() not in SUPPORTED_VISER:
        supported = ", ".join(f"{a}.{b}" for a, b in SUPPORTED_VISER)
        raise UnsupportedViser(
            f"viser {viser.__version__} is installed; the dashboard's access checks wrap viser {supported} "
            "(web/handshake.py): install a supported viser"
        )


class Gatekeeper:
    """Applies one dashboard's `AccessPolicy` to viser's requests and connections."""

    def __init__(self, policy: AccessPolicy, log: RefusalLog) -> None:
        self.policy = policy
        self.log = log
        self.port = 0  # the bound port, once viser has bound it (the cookie's name holds it)
        self.stop_uuid: str | None = None  # the Stop button's, which guests may press
        self.wrapped_calls = 0

    def wrap(self, viser_process_request: ProcessRequest) -> ProcessRequest:
        self.wrapped_calls += 1

        def process_request(connection: ServerConnection, request: Request) -> Any:
            return self._process_request(viser_process_request, connection, request)

        return process_request

    def _process_request(
        self, viser_process_request: ProcessRequest, connection: ServerConnection, request: Request
    ) -> Any:
        websocket = any("websocket" in value.lower() for value in request.headers.get_all("Upgrade"))
        peer = _peer(connection)
        what = f"{'websocket' if websocket else 'HTTP'} {without_query(request.path)}"
        headers: dict[str, str] = {}
        for name in _CHECKED_HEADERS:
            values = request.headers.get_all(name)
            if len(values) > 1:
                return self._refuse(connection, peer, f"{what}: {name} header given {len(values)} times")
            if values:
                headers[name] = values[0]
        port = _local_port(connection) or self.port
        verdict = self.policy.check_request(headers, request.path, websocket=websocket, port=port)
        if verdict.wrong_token:
            self.log.record("token", peer, f"{what}: a wrong operator token")
        if verdict.role is None:
            return self._refuse(connection, peer, f"{what}: {verdict.reason}")
        if websocket:
            _ROLE.set(verdict.role)
            self._gate_messages(connection, verdict.role, peer)
            return viser_process_request(connection, request)
        response = viser_process_request(connection, request)
        if isinstance(response, Response) and response.status_code == http.HTTPStatus.OK:
            for name, value in PAGE_HEADERS.items():
                response.headers[name] = value
            if verdict.set_cookie:
                response.headers["Set-Cookie"] = self.policy.operator_cookie(port)
        return response

    def _refuse(self, connection: ServerConnection, peer: str, reason: str) -> Response:
        self.log.record("request", peer, reason)
        return connection.respond(http.HTTPStatus.FORBIDDEN, "Forbidden: this dashboard refuses the request.\n")

    def _gate_messages(self, connection: ServerConnection, role: Role, peer: str) -> None:
        receive = connection.recv

        async def recv(*args: Any, **kwargs: Any) -> Any:
            while True:
                raw = await receive(*args, **kwargs)
                why = admit_message(role, raw, self.stop_uuid)
                if why is None:
                    return raw
                self.log.record("message", peer, f"{role.value}: {why}")

        connection.recv = recv  # type: ignore[method-assign]


def _local_port(connection: ServerConnection) -> int | None:
    try:
        return int(connection.local_address[1])
    except Exception:  # a connection already gone
        return None


def _peer(connection: ServerConnection) -> str:
    try:
        address = connection.remote_address
        return f"{address[0]}:{address[1]}"
    except Exception:  # a connection already gone
        return "unknown"


def start_viser(gatekeeper: Gatekeeper, *, host: str, port: int, **kwargs: Any) -> viser.ViserServer:
    """A `viser.ViserServer(host=host, port=port, **kwargs)` whose every request passes `gatekeeper`
    (see the module docstring); UnsupportedViser if it could not be wrapped."""
    check_viser_supported()
    module = websockets.asyncio.server
    original = module.serve

    def serve(*args: Any, **kw: Any) -> Any:
        serve_host = kw.get("host", args[1] if len(args) > 1 else None)
        process_request = kw.get("process_request")
        if serve_host == host and process_request is not None:
            kw["process_request"] = gatekeeper.wrap(process_request)
        return original(*args, **kw)

    with _PATCH_LOCK:
        module.serve = serve  # type: ignore[misc,assignment]
        try:
            server = viser.ViserServer(host=host, port=port, **kwargs)
        finally:
            module.serve = original  # type: ignore[misc]
    if gatekeeper.wrapped_calls == 0:
        server.stop()
        raise UnsupportedViser(
            f"viser {viser.__version__} did not start its server through websockets.asyncio.server.serve with a "
            "process_request: the dashboard's access checks cannot be installed (web/handshake.py)"
        )
    gatekeeper.port = int(server.get_port())
    return server
