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
* for the page: forbids framing by other sites and Referers (`PAGE_HEADERS`); the link's valid
  `?token=` is answered with a redirect to the address without it that sets the operator cookie.

And it bounds what each connection costs (`wiithrow.web.limits.Limits`): viser's 50 MiB message
limit becomes `max_message_bytes` (`start_viser` passes websockets' `max_size`; a bigger message
closes the connection with 1009, logged); each connection's `recv` takes a token of its admitted or
its refused `TokenBucket` per message and, when the bucket is empty, waits before reading on (the
sender is pushed back, nothing is dropped); a guest past `max_guests` connected guests, or
connecting more often than `guest_connects_per_s` beyond a burst, gets 503.
Every refusal goes to the `RefusalLog` (rate-limited lines), none as a traceback.
"""

from __future__ import annotations

import asyncio
import contextlib
import contextvars
import http
import threading
import time
import weakref
from collections.abc import Callable, Iterator
from typing import Any

import rich
import viser
import websockets.asyncio.server
from websockets.asyncio.server import ServerConnection
from websockets.exceptions import ConnectionClosedError
from websockets.frames import CloseCode
from websockets.http11 import Request, Response
from websockets.protocol import State

from wiithrow.app.errors import AppError
from wiithrow.web.access import AccessPolicy, RefusalLog, Role, admit_message, without_query
from wiithrow.web.limits import Burst, Limits, TokenBucket

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
#: A connection read more slowly is logged at most once per this many seconds.
_THROTTLE_LOG_S = 10.0

_ROLE: contextvars.ContextVar[Role | None] = contextvars.ContextVar("wiithrow_role", default=None)
_PATCH_LOCK = threading.Lock()

ProcessRequest = Callable[[ServerConnection, Request], Any]


class PortTaken(AppError):
    """The port the dashboard was told to serve on is taken (viser would have served on the next
    free one, an address nobody was given)."""

    def __init__(self, port: int) -> None:
        super().__init__(
            f"port {port} is taken (another wiithrow?); --port N to choose another, --port 0 for any free port"
        )
        self.port = port


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

    def __init__(self, policy: AccessPolicy, log: RefusalLog, limits: Limits | None = None) -> None:
        self.policy = policy
        self.log = log
        self.limits = limits or Limits()
        self._guests: weakref.WeakSet[ServerConnection] = weakref.WeakSet()
        self._guest_connects = TokenBucket(self.limits.guest_connects_per_s, self.limits.guest_connects_burst)
        self.throttled = 0  # messages read late because their connection was over its rate
        self.port = 0  # the bound port, once viser has bound it (the cookie's name holds it)
        self.stop_uuid: str | None = None  # the Stop button's, which guests may press
        self.stop_burst = Burst(self.limits.stop_quiet_s)  # its presses: one notification per burst
        self.wrapped_calls = 0
        self.closing = False  # the dashboard is closing: what connections still hold is read at once

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
            if verdict.role is Role.GUEST:
                full = self.guests() >= self.limits.max_guests
                if full or not self._guest_connects.take():
                    why = (
                        f"{self.limits.max_guests} guests are connected already" if full else "guests connect too often"
                    )
                    self.log.record("request", peer, f"{what}: {why}")
                    return connection.respond(
                        http.HTTPStatus.SERVICE_UNAVAILABLE, "Too many guests: this dashboard refuses the request.\n"
                    )
                self._guests.add(connection)
            _ROLE.set(verdict.role)
            self._gate_messages(connection, verdict.role, peer)
            return viser_process_request(connection, request)
        response: Any
        if verdict.set_cookie:  # the link: set the cookie, then the address without the token
            response = connection.respond(http.HTTPStatus.SEE_OTHER, "")
            response.headers["Location"] = verdict.redirect
            response.headers["Set-Cookie"] = self.policy.operator_cookie(port)
            response.headers["Cache-Control"] = "no-store"
        else:
            response = viser_process_request(connection, request)
        if isinstance(response, Response) and response.status_code in (http.HTTPStatus.OK, http.HTTPStatus.SEE_OTHER):
            for name, value in PAGE_HEADERS.items():
                response.headers[name] = value
        return response

    def guests(self) -> int:
        """Guest connections open now (or opening)."""
        return sum(1 for c in list(self._guests) if c.state is not State.CLOSED)

    def _refuse(self, connection: ServerConnection, peer: str, reason: str) -> Response:
        self.log.record("request", peer, reason)
        return connection.respond(http.HTTPStatus.FORBIDDEN, "Forbidden: this dashboard refuses the request.\n")

    def _gate_messages(self, connection: ServerConnection, role: Role, peer: str) -> None:
        receive = connection.recv
        limits = self.limits
        admitted = TokenBucket(limits.admitted_per_s, limits.admitted_burst)
        refused = TokenBucket(limits.refused_per_s, limits.refused_burst)
        logged = [-float("inf")]

        async def recv(*args: Any, **kwargs: Any) -> Any:
            while True:
                try:
                    raw = await receive(*args, **kwargs)
                except ConnectionClosedError as exc:
                    if exc.sent is not None and exc.sent.code == CloseCode.MESSAGE_TOO_BIG:
                        self.log.record(
                            "message", peer, f"{role.value}: a message over {limits.max_message_bytes} bytes: closed"
                        )
                    raise
                why = admit_message(role, raw, self.stop_uuid)
                if why is not None:
                    self.log.record("message", peer, f"{role.value}: {why}")
                delay = (admitted if why is None else refused).delay()
                # A connection already closed (or a server closing) cannot flood any more: what it
                # left buffered is read at once (its refused messages dropped), not at the rate
                # limit, so that a flood ends with its connection and Stop/close never wait for it.
                if delay > 0 and not self.closing and connection.state is not State.CLOSED:
                    self.throttled += 1
                    now = time.monotonic()
                    if now - logged[0] > _THROTTLE_LOG_S:
                        logged[0] = now
                        rate = limits.admitted_per_s if why is None else limits.refused_per_s
                        what = "messages" if why is None else "refused messages"
                        self.log.record("message", peer, f"{role.value}: over {rate:g} {what}/s: read slower")
                    await asyncio.sleep(delay)
                if why is None:
                    return raw

        connection.recv = recv  # type: ignore[method-assign]


@contextlib.contextmanager
def quiet_viser() -> Iterator[None]:
    """Nothing viser prints through rich's console while it starts or stops reaches the terminal
    (its banner of the bare address, "Server stopped"): the dashboard prints its one link itself."""
    console = rich.get_console()
    was = console.quiet
    console.quiet = True
    try:
        yield
    finally:
        console.quiet = was


def stop_viser(server: viser.ViserServer) -> None:
    """`server.stop()`, quietly (`quiet_viser`)."""
    with quiet_viser():
        server.stop()


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
            kw["max_size"] = gatekeeper.limits.max_message_bytes  # viser asks for 50 MiB
        return original(*args, **kw)

    with _PATCH_LOCK, quiet_viser():
        module.serve = serve  # type: ignore[misc,assignment]
        try:
            server = viser.ViserServer(host=host, port=port, **kwargs)
        finally:
            module.serve = original  # type: ignore[misc]
    if port != 0 and int(server.get_port()) != port:  # viser moved on to the next free port
        stop_viser(server)
        raise PortTaken(port)
    if gatekeeper.wrapped_calls == 0:
        stop_viser(server)
        raise UnsupportedViser(
            f"viser {viser.__version__} did not start its server through websockets.asyncio.server.serve with a "
            "process_request: the dashboard's access checks cannot be installed (web/handshake.py)"
        )
    gatekeeper.port = int(server.get_port())
    return server
