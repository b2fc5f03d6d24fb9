"""The dashboard's "Keep learning" toggle: whether measured throws join the throw library.

`LearningToggle` adds a checkbox to each client's Throw folder when viser counts the client as
connected (on viser's event loop, in the connection's context: its role from
`handshake.current_role`, as `Clients.connected` reads it). A guest's box is disabled and says why
(`GUEST_REASON`); an operator's is disabled while the session refuses a change of its planner
(`Session.refusal(Operation.CHANGE_PLANNER)`: busy while an operation runs), that reason in its
hint, as the buttons show theirs. A change is checked on the server (`change`: the role, then the
refusal; `Session.set_learning` raises it too) and a refused one is set back, logged and told;
every client's box follows the session (`Event.PLANNER`, `Event.OPERATION`).
"""

from __future__ import annotations

import threading
from typing import TYPE_CHECKING, Any

import viser

from wiithrow.app.errors import AppError
from wiithrow.app.session import Event, Operation
from wiithrow.web.access import Role
from wiithrow.web.controls import GUEST_REASON
from wiithrow.web.handshake import current_role

if TYPE_CHECKING:
    from wiithrow.web.server import Dashboard

LABEL = "Keep learning"
HINT = "measured throws join the throw library, which follows a drift (a slower hand, another ball)"


class LearningToggle:
    """Adds the Keep learning box to each client of `dashboard` (before it starts)."""

    def __init__(self, dashboard: Dashboard) -> None:
        self.dashboard = dashboard
        self.session = dashboard.session
        self._lock = threading.Lock()
        self._boxes: dict[int, tuple[viser.GuiCheckboxHandle, Role]] = {}
        dashboard.server.on_client_connect(self.connected)
        dashboard.server.on_client_disconnect(self.left)
        self.session.subscribe(self._changed)

    async def connected(self, client: viser.ClientHandle) -> None:
        self.add(client, current_role() or Role.GUEST)  # no role: a guest (failing closed)

    async def left(self, client: viser.ClientHandle) -> None:
        with self._lock:
            self._boxes.pop(client.client_id, None)

    def add(self, client: viser.ClientHandle, role: Role) -> viser.GuiCheckboxHandle:
        guest = role is not Role.OPERATOR
        with self.dashboard.panels.throw_folder:
            box = client.gui.add_checkbox(
                LABEL,
                initial_value=self.session.learning,
                disabled=guest,
                hint=f"{HINT} ({GUEST_REASON})" if guest else HINT,
            )
        if not guest:
            box.on_update(lambda event: self._clicked(event, box))
        with self._lock:
            self._boxes[client.client_id] = (box, role)
        self._show(box, role)
        return box

    def _clicked(self, event: viser.GuiEvent, box: viser.GuiCheckboxHandle) -> None:
        if bool(box.value) != self.session.learning:
            self.change(event.client, bool(box.value))

    def change(self, client: Any, on: bool) -> bool:
        """The server's check of a change to `on` from `client` (module docstring); True if made."""
        if not self.dashboard.clients.is_operator(client, LABEL):
            self._show_all()
            return False
        why = self.session.refusal(Operation.CHANGE_PLANNER)
        try:
            if why:
                raise AppError(why)
            self.session.set_learning(on)
        except AppError as exc:
            self.dashboard.notify(client, "Not now", f"{LABEL}: {exc}", "red")
            self._show_all()
            return False
        return True

    def _changed(self, event: Event) -> None:
        if event in (Event.PLANNER, Event.OPERATION):
            self._show_all()

    def _show_all(self) -> None:
        with self._lock:
            boxes = list(self._boxes.values())
        for box, role in boxes:
            try:
                self._show(box, role)
            except Exception:  # the client went away
                pass

    def _show(self, box: viser.GuiCheckboxHandle, role: Role) -> None:
        on = self.session.learning
        if box.value != on:
            box.value = on  # type: ignore[misc]  # settable at run time; viser 1.1's type says read-only
        if role is not Role.OPERATOR:
            return
        why = self.session.refusal(Operation.CHANGE_PLANNER) or ""
        if box.disabled != bool(why):
            box.disabled = bool(why)
        hint = f"{HINT} (now: {why})" if why else HINT
        if box.hint != hint:
            box.hint = hint
