"""What a Zenoh configuration exposes beyond this host, and whether Zenoh's own security covers it.

`exposure(config)` reads a `zenoh.Config` (as `zenoh_session.load_config` gives it) the way Zenoh
will use it, with Zenoh 1.x's defaults for what the file leaves out (a peer listens on
`tcp/[::]:0`, a router on `tcp/[::]:7447`; multicast scouting is on), and returns the first thing
that reaches past this host's loopback without authentication, in words, or None:

- an endpoint it listens on whose address is not loopback (127.0.0.0/8, ::1, `localhost`; a
  Unix socket or pipe is local), unless the listener authenticates who connects: mutual TLS
  (`tls/` or `quic/`, `transport/link/tls/enable_mtls` with `root_ca_certificate`,
  `listen_certificate`, `listen_private_key`) or user/password with a `dictionary_file` of the
  users it accepts (`transport/auth/usrpwd`);
- an endpoint it connects to that is not loopback, unless the link is mutual TLS (the other side's
  certificate checked against `root_ca_certificate`, this side's shown: `connect_certificate`,
  `connect_private_key`) or this side has a `user` and `password` to show;
- multicast scouting on (`scouting/multicast/enabled`, Zenoh's default): it joins 224.0.0.224 on a
  network interface, announces this session's endpoints there and connects to whoever answers;
  allowed only with an authenticated listener or mutual TLS as above.

Measured on eclipse-zenoh 1.10 (tests/app/test_zenoh_security.py): with mutual TLS a peer
without a certificate, or with one of another CA, opens no link (one of the CA under another name
does, and the access-control rules of examples/zenoh/ give it nothing); with a dictionary a peer
without credentials or with a wrong password opens none, the dictionary's user does. A listener
with no dictionary has nothing to check a peer's user against, and a TLS listener without
`enable_mtls` asks no certificate of its peers: neither counts as authentication here.
"""

from __future__ import annotations

import ipaddress
import json
from dataclasses import dataclass
from typing import Any

#: Zenoh 1.x's listen endpoints when a configuration names none (zenoh's DEFAULT_CONFIG.json5).
DEFAULT_LISTEN = {"router": ["tcp/[::]:7447"], "peer": ["tcp/[::]:0"], "client": []}
#: Protocols whose endpoints never leave the host whatever their address.
LOCAL_PROTOCOLS = {"unixsock-stream", "unixpipe"}
#: Protocols whose links mutual TLS authenticates.
TLS_PROTOCOLS = {"tls", "quic"}


@dataclass(frozen=True)
class Security:
    """The authentication a configuration sets up, as Zenoh reads it."""

    mtls_listen: bool  # a TLS listener that asks every peer for a certificate of the CA
    mtls_connect: bool  # a TLS connector that checks the other side and shows its own certificate
    usrpwd_listen: bool  # a dictionary of the users this side accepts
    usrpwd_connect: bool  # a user and a password this side shows

    def covers_listen(self, protocol: str) -> bool:
        return self.usrpwd_listen or (self.mtls_listen and protocol in TLS_PROTOCOLS)

    def covers_connect(self, protocol: str) -> bool:
        return self.usrpwd_connect or (self.mtls_connect and protocol in TLS_PROTOCOLS)


def _get(config: Any, key: str) -> Any:
    try:
        return json.loads(config.get_json(key))
    except Exception:  # a key this version of Zenoh does not know: not set
        return None


def _for_mode(value: Any, mode: str) -> Any:
    """A value that is either one for every mode or a {router, peer, client} table."""
    if isinstance(value, dict) and set(value) <= {"router", "peer", "client"}:
        return value.get(mode)
    return value


def _endpoints(value: Any) -> list[str]:
    """Endpoint strings from a list of strings or of {strategy, locators} groups."""
    found: list[str] = []
    for item in value or []:
        if isinstance(item, str):
            found.append(item)
        elif isinstance(item, dict):
            found.extend(str(locator) for locator in item.get("locators", []))
    return found


def split_endpoint(endpoint: str) -> tuple[str, str]:
    """(protocol, host) of `proto/address[?metadata][#config]`; host without port or brackets."""
    protocol, _, address = endpoint.partition("/")
    address = address.split("?", 1)[0].split("#", 1)[0]
    if address.startswith("["):  # [v6]:port
        host = address[1 : address.find("]")] if "]" in address else address[1:]
    else:
        host = address.rsplit(":", 1)[0] if ":" in address else address
    return protocol.lower(), host


def is_loopback(endpoint: str) -> bool:
    protocol, host = split_endpoint(endpoint)
    if protocol in LOCAL_PROTOCOLS:
        return True
    if host.lower() == "localhost":
        return True
    try:
        return ipaddress.ip_address(host.split("%", 1)[0]).is_loopback
    except ValueError:  # a host name: where it resolves is another host's business
        return False


def security(config: Any) -> Security:
    tls = _get(config, "transport/link/tls") or {}
    usrpwd = _get(config, "transport/auth/usrpwd") or {}
    mtls = bool(tls.get("enable_mtls")) and bool(tls.get("root_ca_certificate"))
    return Security(
        mtls_listen=mtls and bool(tls.get("listen_certificate")) and bool(tls.get("listen_private_key")),
        mtls_connect=mtls and bool(tls.get("connect_certificate")) and bool(tls.get("connect_private_key")),
        usrpwd_listen=bool(usrpwd.get("dictionary_file")),
        usrpwd_connect=bool(usrpwd.get("user")) and bool(usrpwd.get("password")),
    )


def listen_endpoints(config: Any) -> list[str]:
    mode = _get(config, "mode") or "peer"
    value = _for_mode(_get(config, "listen/endpoints"), mode)
    return _endpoints(DEFAULT_LISTEN.get(mode, []) if value is None else value)


def connect_endpoints(config: Any) -> list[str]:
    mode = _get(config, "mode") or "peer"
    return _endpoints(_for_mode(_get(config, "connect/endpoints"), mode))


def multicast_scouting(config: Any) -> bool:
    mode = _get(config, "mode") or "peer"
    enabled = _for_mode(_get(config, "scouting/multicast/enabled"), mode)
    return True if enabled is None else bool(enabled)


def exposure(config: Any) -> str | None:
    """What `config` opens past loopback without authentication (words), or None."""
    secured = security(config)
    for endpoint in listen_endpoints(config):
        if not is_loopback(endpoint) and not secured.covers_listen(split_endpoint(endpoint)[0]):
            return f"listens on {endpoint} beyond this host's loopback without authentication"
    for endpoint in connect_endpoints(config):
        if not is_loopback(endpoint) and not secured.covers_connect(split_endpoint(endpoint)[0]):
            return f"connects to {endpoint} beyond this host's loopback without authentication"
    if multicast_scouting(config) and not (secured.usrpwd_listen or secured.mtls_listen or secured.mtls_connect):
        return "has multicast scouting on (224.0.0.224:7446, Zenoh's default) without authentication"
    return None
