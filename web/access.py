"""Who may use the dashboard, and what each may do: the Host, Origin and token checks and the roles.

Owns the access rules, as pure functions of what a request or a message carries (no sockets, no
viser: `wiithrow.web.handshake` applies them to viser's connections):

* **Host** (every HTTP and websocket request): the name must be one the server answers to: a
  loopback name (`localhost`, 127.x.y.z, ::1), the bound address, or a name given with
  `--allow-host`; when bound to every interface (0.0.0.0, ::), any IP literal too (a DNS-rebinding
  page always arrives under its own *name*). Otherwise 403.
* **Origin** (when present, on any request; mandatory on a websocket unless a valid token comes
  with it): scheme, host and port must be the dashboard's own, as the request's Host names it
  (http only). A page from another origin, another port of this machine included, gets 403
  before a single message. A websocket without Origin (a native client) needs the token.
* **The operator token**: generated at start (`new_token`), or given (`--token`, `--token-file`,
  `WIITHROW_TOKEN`; `resolve_token` checks it). A request carries it as `?token=` (the printed
  link) or as `Authorization: Bearer` (a native client), compared in constant time
  (`hmac.compare_digest`), never logged (paths are logged without their query).
* **The operator cookie**: the link's page load is answered with a redirect to the address without
  the token (out of the address bar and the history) that sets a cookie (`operator_cookie`):
  `expiry.nonce.HMAC(key, port.expiry.nonce)` with a key drawn at random when the server starts
  (a restart invalidates every cookie; nothing in it derives from the token), good for
  `cookie_max_age_s` (12 h by default, checked here and told to the browser), HttpOnly,
  SameSite=Strict, named and signed for the dashboard's port (a browser sends cookies to every
  port of a host: another local server gets a cookie it cannot use here, and one for another
  port is not valid on this one). On a websocket it counts only with the dashboard's own Origin:
  a native client (no Origin) authenticates with the token itself.
* **Roles**: a connection with a valid token is an `OPERATOR`; one without, or with a wrong one,
  is a `GUEST`: it sees everything live and may send only what watching needs (its camera) and
  Stop. `admit_message` decides, per message a client sends, whether it reaches viser; what it
  refuses is logged (`RefusalLog`, rate-limited, bounded). Everyone's GUI messages may change a
  value only (never an element's `disabled`, `visible`, ...), and nobody may open one of viser's
  public share tunnels (they would put the robot's controls on the internet).
"""

from __future__ import annotations

import enum
import hashlib
import hmac
import ipaddress
import logging
import os
import re
import secrets
import threading
import time
from collections import deque
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from http.cookies import CookieError, SimpleCookie
from pathlib import Path
from urllib.parse import parse_qs, parse_qsl, urlencode, urlsplit

from wiithrow.app.errors import AppError
from wiithrow.web.wire import GuiUpdateMessage, decode_client_message

LOG = logging.getLogger("wiithrow.web.access")

#: The environment variable a service puts the operator token in.
TOKEN_ENV = "WIITHROW_TOKEN"
#: A given token: at least this many characters of the URL-safe alphabet (it goes into links).
MIN_TOKEN_LENGTH = 16
_TOKEN_CHARS = re.compile(r"[A-Za-z0-9._~-]+")
WILDCARD_HOSTS = ("0.0.0.0", "::", "")
#: Messages a guest may send: watching needs its camera, and the answer to the server's question of
#: which renderer the page has (`wiithrow.web.light_scene`); Stop is everyone's (checked by uuid).
GUEST_MESSAGES = frozenset({"ViewerCameraMessage", "LocalStorageGetItemResponseMessage"})
#: Messages nobody may send: they ask viser to open a public share tunnel to this server.
NOBODY_MESSAGES = frozenset({"ShareUrlRequest", "ShareUrlDisconnect"})


class Role(enum.Enum):
    OPERATOR = "operator"  # holds the token: may start operations
    GUEST = "guest"  # sees everything live, may press Stop, starts nothing


# -- the token ----------------------------------------------------------------------------------


@dataclass(frozen=True)
class Token:
    """The operator token and where it came from ("generated", "--token", a file, the environment)."""

    value: str
    source: str

    @property
    def given(self) -> bool:
        """Chosen by whoever started the server (not generated now)."""
        return self.source != "generated"

    @property
    def printable(self) -> bool:
        """May be printed in the start line: not a service's secret read from a file or the environment."""
        return self.source in ("generated", "--token")

    def __repr__(self) -> str:  # never the value
        return f"Token(source={self.source!r})"


def new_token() -> Token:
    return Token(secrets.token_urlsafe(32), "generated")


def check_token(value: str, source: str) -> Token:
    """A given token, or AppError saying what is wrong with it (never echoing it)."""
    if len(value) < MIN_TOKEN_LENGTH:
        raise AppError(f"the operator token from {source} is too short: give at least {MIN_TOKEN_LENGTH} characters")
    if not _TOKEN_CHARS.fullmatch(value):
        raise AppError(f"the operator token from {source} may hold only letters, digits and . _ ~ -")
    return Token(value, source)


def resolve_token(value: str | None, file: str | None, environ: Mapping[str, str] | None = None) -> Token:
    """The token from `--token`, else `--token-file`, else $WIITHROW_TOKEN, else a new random one."""
    environ = os.environ if environ is None else environ
    if value is not None and file is not None:
        raise AppError("give the operator token once: --token or --token-file, not both")
    if value is not None:
        return check_token(value, "--token")
    if file is not None:
        try:
            text = Path(file).read_text(encoding="utf-8").strip()
        except (OSError, UnicodeDecodeError) as exc:
            reason = exc.strerror if isinstance(exc, OSError) and exc.strerror else type(exc).__name__
            raise AppError(f"cannot read the operator token file {file}: {reason}") from None
        if not text:
            raise AppError(f"the operator token file {file} is empty")
        return check_token(text, f"the file {file}")
    if environ.get(TOKEN_ENV):
        return check_token(environ[TOKEN_ENV], f"${TOKEN_ENV}")
    return new_token()


def same_secret(given: str, expected: str) -> bool:
    """Constant-time comparison (the time does not depend on where the strings differ)."""
    return hmac.compare_digest(given.encode("utf-8", "replace"), expected.encode("utf-8"))


# -- who can reach the port -------------------------------------------------------------------------


def is_local_host(host: str) -> bool:
    """True for addresses only this machine can reach."""
    return host in ("127.0.0.1", "localhost", "::1") or host.startswith("127.")


def exposure_note(host: str, port: int) -> str:
    """What binding beyond this machine means (printed at start)."""
    return (
        f"NOTE: the dashboard listens on {host}:{port}: whoever reaches this port sees the robot live as a "
        "guest (and may press Stop); only holders of the operator token can move it."
    )


def refuse_exposure_without_token(host: str, token: Token) -> None:
    """Binding beyond loopback needs a token chosen for it (a file or the environment, for a service)."""
    if not is_local_host(host) and not token.given:
        raise AppError(
            f"--host {host} lets other machines reach the dashboard: give it an operator token "
            f"(--token-file FILE or ${TOKEN_ENV}, at least {MIN_TOKEN_LENGTH} characters) so that only "
            "operators can move the robot"
        )


def _ip(name: str) -> ipaddress.IPv4Address | ipaddress.IPv6Address | None:
    try:
        return ipaddress.ip_address(name)
    except ValueError:
        return None


def split_host(value: str) -> tuple[str, int | None] | None:
    """A Host header's (lower-case name without brackets, port or None); None if malformed."""
    try:
        parts = urlsplit("//" + value.strip())
        name, port = parts.hostname, parts.port
    except ValueError:
        return None
    if not name or parts.username is not None or parts.path or parts.query:
        return None
    return name.lower(), port


# -- requests -------------------------------------------------------------------------------------


@dataclass(frozen=True)
class Verdict:
    """What to do with a request: serve it as `role`, or refuse it (`role` None) for `reason`."""

    role: Role | None
    reason: str = ""
    wrong_token: bool = False  # a token came and was wrong (the request is served as a guest)
    set_cookie: bool = False  # the link's valid token: give the page its operator cookie
    redirect: str = ""  # with set_cookie: the same address without the token


#: How long an operator cookie is good for (s).
COOKIE_MAX_AGE_S = 12 * 3600.0


class AccessPolicy:
    """The rules of the module docstring for one dashboard: its token, bound address, extra names,
    and the key of its operator cookies (new at every start)."""

    def __init__(
        self,
        token: Token,
        bound_host: str,
        allowed_hosts: tuple[str, ...] = (),
        *,
        cookie_max_age_s: float = COOKIE_MAX_AGE_S,
        clock: Callable[[], float] = time.time,
    ) -> None:
        if not cookie_max_age_s > 0:
            raise ValueError(f"cookie_max_age_s must be > 0, got {cookie_max_age_s}")
        self.token = token
        self.bound_host = bound_host.strip("[]").lower()
        self.allowed_hosts = frozenset(h.strip().lower() for h in allowed_hosts if h.strip())
        self.cookie_max_age_s = float(cookie_max_age_s)
        self._clock = clock
        self._cookie_key = secrets.token_bytes(32)

    def __repr__(self) -> str:
        return f"AccessPolicy(bound_host={self.bound_host!r}, allowed_hosts={sorted(self.allowed_hosts)})"

    def host_allowed(self, name: str) -> bool:
        if name == "localhost" or name in self.allowed_hosts or name == self.bound_host:
            return True
        ip = _ip(name)
        if ip is None:
            return False
        return ip.is_loopback or self.bound_host in WILDCARD_HOSTS

    def cookie_name(self, port: int) -> str:
        return f"wiithrow-operator-{port}"

    def operator_cookie(self, port: int) -> str:
        """A Set-Cookie header value that makes the page's own websocket an operator's (a new
        nonce each time; see the module docstring)."""
        expires = int(self._clock() + self.cookie_max_age_s)
        nonce = secrets.token_urlsafe(12)
        value = f"{expires}.{nonce}.{self._cookie_mac(port, expires, nonce)}"
        return (
            f"{self.cookie_name(port)}={value}; Path=/; Max-Age={int(self.cookie_max_age_s)}; HttpOnly; SameSite=Strict"
        )

    def _cookie_mac(self, port: int, expires: int, nonce: str) -> str:
        return hmac.new(self._cookie_key, f"{port}.{expires}.{nonce}".encode(), hashlib.sha256).hexdigest()

    def valid_cookie(self, value: str, port: int) -> bool:
        """One of this server's operator cookies for `port`, not expired."""
        parts = value.split(".")
        if len(parts) != 3 or not (0 < len(parts[0]) <= 12 and parts[0].isascii() and parts[0].isdigit()):
            return False
        expires = int(parts[0])
        return same_secret(parts[2], self._cookie_mac(port, expires, parts[1])) and self._clock() < expires

    def check_request(self, headers: Mapping[str, str], path: str, *, websocket: bool, port: int) -> Verdict:
        """Apply the Host, Origin and token rules to one request (see the module docstring)."""
        host_header = headers.get("Host")
        host = split_host(host_header) if host_header is not None else None
        if host is None:
            return Verdict(None, "no valid Host header")
        if not self.host_allowed(host[0]):
            return Verdict(None, f"Host {host_header!r} is not a name this dashboard answers to")
        origin = headers.get("Origin")
        if origin is not None and not _same_origin(origin, host):
            return Verdict(None, f"Origin {origin!r} is not this dashboard's (http://{host_header})")
        query_token = _query_token(path)
        by_token = (query_token is not None and same_secret(query_token, self.token.value)) or self._bearer(headers)
        # a websocket's cookie counts only with the page's own Origin (checked above)
        operator = by_token or ((not websocket or origin is not None) and self._cookie(headers, port))
        wrong = not operator and (query_token is not None or headers.get("Authorization") is not None)
        if websocket and origin is None and not operator:
            return Verdict(None, "a client without Origin (not a browser) needs the operator token", wrong_token=wrong)
        role = Role.OPERATOR if operator else Role.GUEST
        if by_token and not websocket and query_token is not None:
            return Verdict(role, set_cookie=True, redirect=without_token(path))
        return Verdict(role, wrong_token=wrong)

    def _bearer(self, headers: Mapping[str, str]) -> bool:
        auth = headers.get("Authorization")
        return auth is not None and auth.startswith("Bearer ") and same_secret(auth[7:].strip(), self.token.value)

    def _cookie(self, headers: Mapping[str, str], port: int) -> bool:
        raw = headers.get("Cookie")
        if raw is None:
            return False
        try:
            morsel = SimpleCookie(raw).get(self.cookie_name(port))
        except CookieError:
            return False
        return morsel is not None and self.valid_cookie(morsel.value, port)


def _same_origin(origin: str, host: tuple[str, int | None]) -> bool:
    try:
        parts = urlsplit(origin)
        name, port = parts.hostname, parts.port
    except ValueError:
        return False
    if parts.scheme != "http" or not name or parts.path not in ("", "/"):
        return False
    return (name.lower(), port or 80) == (host[0], host[1] or 80)


def _query_token(path: str) -> str | None:
    values = parse_qs(urlsplit(path).query).get("token")
    return values[-1] if values else None


def without_token(path: str) -> str:
    """A request path without its `token` query parameter (the others kept)."""
    parts = urlsplit(path)
    query = urlencode([(k, v) for k, v in parse_qsl(parts.query, keep_blank_values=True) if k != "token"])
    return (parts.path or "/") + (f"?{query}" if query else "")


def without_query(path: str) -> str:
    """A request path as it may be logged (the query may hold the token)."""
    return path.split("?", 1)[0]


# -- messages -------------------------------------------------------------------------------------


def admit_message(role: Role, raw: bytes | str, stop_uuid: str | None) -> str | None:
    """None if a client of `role` may send this message to viser, else why not (one line). The
    message is decoded against the page's schema first (`wiithrow.web.wire`: bounded depth, no
    traceback for any input)."""
    if not isinstance(raw, bytes):
        return "a text frame (viser's clients send binary)"
    message = decode_client_message(raw)
    if isinstance(message, str):
        return message
    kind = type(message).__name__
    if kind in NOBODY_MESSAGES:
        return f"{kind}: share tunnels are disabled (they would publish the robot's controls)"
    if isinstance(message, GuiUpdateMessage):
        if set(message.updates) != {"value"}:
            return "a GUI message that changes more than a value"
        if role is Role.OPERATOR or (stop_uuid is not None and message.uuid == stop_uuid):
            return None
        return "GuiUpdateMessage: a guest may press Stop only"
    if role is Role.OPERATOR or kind in GUEST_MESSAGES:
        return None
    return f"{kind}: a guest may watch and press Stop only"


def is_stop(raw: bytes, stop_uuid: str | None) -> bool:
    """An admitted message that presses Stop."""
    message = decode_client_message(raw)
    return isinstance(message, GuiUpdateMessage) and stop_uuid is not None and message.uuid == stop_uuid


# -- the record of refusals ---------------------------------------------------------------------------


@dataclass(frozen=True)
class Refusal:
    t: float  # time.time()
    kind: str  # "request" (refused with 403), "message" (ignored), "token" (a wrong token)
    peer: str
    reason: str


class RefusalLog:
    """Logs refused requests and ignored messages (warnings on `wiithrow.web.access`): at most
    `burst` lines per `period_s`, the rest counted and reported with the next line; keeps the last
    `keep` refusals and the counts by kind (bounded: a scanner cannot grow it)."""

    def __init__(
        self, *, burst: int = 10, period_s: float = 10.0, keep: int = 100, clock: Callable[[], float] = time.monotonic
    ) -> None:
        self.recent: deque[Refusal] = deque(maxlen=keep)
        self.counts = {"request": 0, "message": 0, "token": 0}
        self._burst, self._period = burst, period_s
        self._clock = clock
        self._window_start = -float("inf")
        self._logged = 0
        self._suppressed = 0
        self._lock = threading.Lock()

    def record(self, kind: str, peer: str, reason: str) -> None:
        with self._lock:
            self.counts[kind] = self.counts.get(kind, 0) + 1
            self.recent.append(Refusal(time.time(), kind, peer, reason))
            now = self._clock()
            if now - self._window_start > self._period:
                self._window_start, self._logged = now, 0
            if self._logged >= self._burst:
                self._suppressed += 1
                return
            self._logged += 1
            suppressed, self._suppressed = self._suppressed, 0
        what = {"request": "refused a request", "message": "ignored a message", "token": "a wrong operator token"}
        more = f" ({suppressed} more not logged)" if suppressed else ""
        LOG.warning("%s from %s: %s%s", what.get(kind, kind), peer, reason, more)
