"""The connected browsers: each one's role and its own controls, and the check every click passes.

Owns `Clients`. When viser counts a client as connected (its first camera message), `connected`
runs on viser's event loop in that connection's context, reads the role the handshake gave it
(`wiithrow.web.handshake.current_role`; none: a guest, failing closed) and builds its controls
(`wiithrow.web.controls.ClientControls`); a client that leaves is forgotten (what is kept is
bounded by the connected clients). `operator_seen` is set once an operator's page has connected
with its controls (what `wiithrow demo` waits for before its automatic calibration, so that the
page shows it from its first pose). `is_operator` is the server-side check of every click that
would start something: a guest's (forged, since its buttons are disabled) is refused, logged in
the `RefusalLog` and answered with a notification; `may_start` adds the operation's own
precondition (`Session.refusal`, the function that disabled the button): a click whose
precondition fails is refused, logged and answered with that text, and starts nothing.
"""

from __future__ import annotations

import threading
from collections.abc import Callable
from typing import Any

import viser

from wiithrow.app.session import Operation, Session
from wiithrow.web.access import RefusalLog, Role
from wiithrow.web.controls import GUEST_REASON, ClientControls, label
from wiithrow.web.handshake import current_role

Build = Callable[[viser.ClientHandle, Role], ClientControls]
Notify = Callable[[Any, str, str, Any], None]  # (client or None for all, title, body, colour name)


class Clients:
    """The connected clients of one dashboard (see the module docstring)."""

    def __init__(self, server: viser.ViserServer, build: Build, refusals: RefusalLog, notify: Notify) -> None:
        self._build = build
        self.refusals = refusals
        self._notify = notify
        self._lock = threading.Lock()
        self.roles: dict[int, Role] = {}  # client id -> role
        self._controls: dict[int, ClientControls] = {}
        self.operator_seen = threading.Event()
        self.on_left: Callable[[int], None] | None = None  # told the id of each client that left
        server.on_client_connect(self.connected)
        server.on_client_disconnect(self.left)

    async def connected(self, client: viser.ClientHandle) -> None:
        role = current_role()
        if role is None:  # not a connection the handshake saw
            self.refusals.record("message", f"client {client.client_id}", "role unknown: treated as a guest")
            role = Role.GUEST
        controls = self._build(client, role)
        with self._lock:
            self.roles[client.client_id] = role
            self._controls[client.client_id] = controls
        if role is Role.OPERATOR:
            self.operator_seen.set()

    async def left(self, client: viser.ClientHandle) -> None:
        with self._lock:
            self.roles.pop(client.client_id, None)
            self._controls.pop(client.client_id, None)
        if self.on_left is not None:
            self.on_left(client.client_id)

    def controls(self) -> list[ClientControls]:
        with self._lock:
            return list(self._controls.values())

    def role(self, client: viser.ClientHandle | None) -> Role | None:
        """The role of a connected client (None for no client or one that is not connected)."""
        if client is None:
            return None
        with self._lock:
            return self.roles.get(client.client_id)

    def is_operator(self, client: viser.ClientHandle | None, what: str) -> bool:
        """True if `client` is an operator's; otherwise `what` is refused, logged and the client told."""
        role = self.role(client)
        if role is Role.OPERATOR:
            return True
        who = f"client {client.client_id}" if client is not None else "no client"
        self.refusals.record("message", who, f"{what} from a {role.value if role else 'unknown'} client: refused")
        self._notify(client, "View only", GUEST_REASON, "yellow")
        return False

    def may_start(
        self, client: viser.ClientHandle | None, op: Operation, session: Session, *, terminal: bool = False
    ) -> bool:
        """True if `client`'s click may start `op` now: an operator's (no client only where
        `terminal` allows it: the command line, tests) and `session.refusal(op)` is None.
        Otherwise nothing starts: refused, logged, the client told why (the button's reason)."""
        if (client is not None or not terminal) and not self.is_operator(client, label(op)):
            return False
        why = session.refusal(op)
        if why is None:
            return True
        who = f"client {client.client_id}" if client is not None else "no client"
        self.refusals.record("message", who, f"{label(op)} refused: {why}")
        self._notify(client, "Busy" if session.busy else f"{label(op)}: not now", why, "yellow")
        return False
