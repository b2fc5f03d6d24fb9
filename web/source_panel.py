"""The dashboard's Marker source folder: which publisher's markers move the arm, and the operator's
confirmation of one (`serve --markers-from`: `wiithrow.app.network.source_pin`).

`SourcePanel` adds a folder every browser shares: the publisher followed now (its Zenoh id and
stream, and the host, pid and command it announced) and those that ask to be followed (the same,
with their frames so far and when they last sent), refreshed every `REFRESH_S`. Each client gets
its own Publisher list and Follow button when viser counts it as connected (on viser's event loop,
its role from `handshake.current_role`, as `Clients.connected` reads it). A guest's are disabled
and say why (`GUEST_REASON`); an operator's button is disabled while no publisher asks to be
followed (`NOBODY_ASKS`) or while the session refuses it (`Session.refusal(Operation.FOLLOW_SOURCE)`:
busy while an operation runs), the reason in its hint and in a visible line of the folder, as the
other buttons show theirs. A click is checked on the server (`Clients.may_start`: the role, then
the refusal) and runs `Session.follow_source` in the dashboard's operation runner; a publisher that
stopped asking meanwhile is refused there with the session's one line.
"""

from __future__ import annotations

import threading
from collections.abc import Callable
from typing import TYPE_CHECKING

import viser

from wiithrow.app.network.source_pin import ChoosesSource, SourceCandidate
from wiithrow.app.session import Operation
from wiithrow.web.access import Role
from wiithrow.web.controls import GUEST_REASON
from wiithrow.web.handshake import current_role

if TYPE_CHECKING:
    from wiithrow.web.server import Dashboard

#: How often the folder shows the publishers again (s): one that stopped leaves the list within it.
REFRESH_S = 1.0
FOLLOW = "Follow this publisher"
FOLLOW_HINT = "use the chosen publisher's markers from now on (only a process of yours on the tracking host)"
NOBODY_ASKS = "no other publisher asks to be followed now"
NONE_LISTED = "(none asks to be followed)"


def candidate_label(c: SourceCandidate) -> str:
    """How a publisher is named in a Publisher list: where it runs and its ids (shortened)."""
    where = f"{c.origin.host} pid {c.origin.pid}" if c.origin is not None else "where unknown"
    jumped = ", the followed one after a jump" if c.followed else ""
    return f"{where}{jumped} · {c.source[:12]}/{c.stream}"


def _cell(text: str) -> str:
    return text.replace("|", "/").replace("`", "'")


def sources_text(followed: SourceCandidate | None, asking: list[SourceCandidate]) -> str:
    """The folder's shared text: who is followed, and who asks to be followed (markdown)."""
    if followed is None:
        lines = ["**No publisher followed yet**: Track target and Measure landing wait for one."]
    else:
        where = _cell(followed.origin.describe()) if followed.origin is not None else "where unknown"
        lines = [f"**Following** `{followed.source}` / `{followed.stream}`: {where}"]
    if asking:
        lines += [
            "",
            "**Asking to be followed** (confirm one only if it is your tracking host's process):",
            "",
            "| source / stream | host | pid | command | frames | last sent |",
            "|---|---|---|---|---|---|",
        ]
        for c in asking:
            o = c.origin
            host, pid, command = (_cell(o.host), str(o.pid), f"`{_cell(o.command)}`") if o else ("?", "?", "?")
            lines.append(
                f"| `{c.source[:12]}` / `{c.stream}` | {host} | {pid} | {command} | {c.frames} | {c.age_s:.1f} s ago |"
            )
    return "\n".join(lines)


class SourceControls:
    """One client's Publisher list, Follow button and the line that says why it is disabled."""

    def __init__(
        self, client: viser.ClientHandle, role: Role, on_follow: Callable[[viser.GuiEvent, str], None]
    ) -> None:
        self.client = client
        self.role = role
        guest = role is not Role.OPERATOR
        gui = client.gui
        hint = f"{FOLLOW_HINT} ({GUEST_REASON})" if guest else FOLLOW_HINT
        self.publisher = gui.add_dropdown("Publisher", (NONE_LISTED,), disabled=True, hint=hint)
        self.follow = gui.add_button(FOLLOW, icon=viser.Icon.CHECK, disabled=True, hint=hint)
        self.reason = gui.add_markdown(GUEST_REASON if guest else "", visible=guest)
        if not guest:
            self.follow.on_click(lambda event: on_follow(event, str(self.publisher.value)))

    def show(self, labels: tuple[str, ...], why: str) -> None:
        """The publishers offered and why Follow is disabled ("" when it may be pressed)."""
        options = labels or (NONE_LISTED,)
        if tuple(self.publisher.options) != options:
            self.publisher.options = options
        if self.role is not Role.OPERATOR:
            return
        if self.publisher.disabled != (not labels):
            self.publisher.disabled = not labels
        if self.follow.disabled != bool(why):
            self.follow.disabled = bool(why)
        hint = f"{FOLLOW_HINT} (now: {why})" if why else FOLLOW_HINT
        if self.follow.hint != hint:
            self.follow.hint = hint
        text = f"Not now: *{FOLLOW}*: {why}" if why else ""
        if self.reason.content != text:
            self.reason.content = text
        if self.reason.visible != bool(text):
            self.reason.visible = bool(text)


class SourcePanel:
    """Adds the Marker source folder to `dashboard` (before it starts) when its rig's publisher is
    chosen (`ChoosesSource`: `serve --markers-from`); `close()` stops its refresh."""

    def __init__(self, dashboard: Dashboard) -> None:
        rig = dashboard.world.rig
        assert isinstance(rig, ChoosesSource)
        self.dashboard = dashboard
        self.session = dashboard.session
        self.rig = rig
        self._lock = threading.Lock()
        self.controls: dict[int, SourceControls] = {}
        self._offered: dict[str, SourceCandidate] = {}
        with dashboard.server.gui.add_folder("Marker source") as self.folder:
            self.text = dashboard.server.gui.add_markdown(sources_text(None, []))
        dashboard.server.on_client_connect(self.connected)
        dashboard.server.on_client_disconnect(self.left)
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, name="wiithrow-web-sources", daemon=True)
        self._thread.start()

    async def connected(self, client: viser.ClientHandle) -> None:
        self.add(client, current_role() or Role.GUEST)  # no role: a guest (failing closed)

    async def left(self, client: viser.ClientHandle) -> None:
        with self._lock:
            self.controls.pop(client.client_id, None)

    def add(self, client: viser.ClientHandle, role: Role) -> SourceControls:
        with self.folder:
            controls = SourceControls(client, role, self._clicked)
        with self._lock:
            self.controls[client.client_id] = controls
        self.refresh()
        return controls

    def _run(self) -> None:
        while not self._stop.wait(REFRESH_S):
            try:
                self.refresh()
            except Exception:  # a client that went away mid-update; the next refresh redraws
                pass

    def refresh(self) -> None:
        """Show who is followed and who asks to be followed, and each client's Follow as it may be pressed."""
        asking = self.rig.candidates()
        text = sources_text(self.rig.followed(), asking)
        if self.text.content != text:
            self.text.content = text
        offered = {candidate_label(c): c for c in asking}
        why = self.session.refusal(Operation.FOLLOW_SOURCE) or ("" if offered else NOBODY_ASKS)
        with self._lock:
            self._offered = offered
            controls = list(self.controls.values())
        for c in controls:
            c.show(tuple(offered), why)

    def _clicked(self, event: viser.GuiEvent, label: str) -> None:
        self.follow(event.client, label)

    def follow(self, client: viser.ClientHandle | None, label: str) -> bool:
        """The server's check of a click on Follow with `label` chosen (module docstring); True if started."""
        if not self.dashboard.clients.may_start(client, Operation.FOLLOW_SOURCE, self.session):
            return False
        with self._lock:
            chosen = self._offered.get(label)
        if chosen is None:
            self.dashboard.notify(client, "Marker source", f"{label}: {NOBODY_ASKS} under that name", "yellow")
            return False

        def follow() -> str:
            try:
                return self.session.follow_source(chosen.source, chosen.stream)
            finally:
                self.refresh()

        def done(notice: str) -> tuple[str, str]:
            return ("Marker source", notice)

        return self.dashboard.runner.start(Operation.FOLLOW_SOURCE, follow, client=client, done=done)

    def close(self) -> None:
        self._stop.set()
        self._thread.join(timeout=2.0)


def source_panel(dashboard: Dashboard) -> SourcePanel | None:
    """The Marker source folder when `dashboard`'s markers come from a chosen publisher, else None."""
    return SourcePanel(dashboard) if isinstance(dashboard.world.rig, ChoosesSource) else None
