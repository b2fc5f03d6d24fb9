"""The Library folder: the throw library in use, its versions, what the learning did, and going back.

Owns `LibraryPanel` (the shared part: the library in use and its library folder, what the learning
did with the last throw (joined, refused and why, kept but not used), the calibration in use beside
the one it replaced, a trained library waiting for the operator's choice, the newest versions) and
`LibraryInputs` (each browser's own: the version number and *Use this version*, and the choice
after *Finish training*: *Use the new library* / *Keep the library in use*; a guest's are disabled
and say why, an operator's disabled ones say the session's refusal). `choice_dialog` is the dialog
*Finish training* opens in the operator's browser: the new library and the one in use side by
side (`wiithrow.app.throws.library_compare`), and the two buttons.

Every click is checked on the server (`accept`: the role, then `Session.refusal(op)`) and runs in
the dashboard's `OperationRunner`: `Session.use_version` (`Operation.LIBRARY_USE`) and
`Session.choose_trained_library` (`Operation.LIBRARY_CHOOSE`). The Training panel makes this panel
and hands it its clients and the session's changes.
"""

from __future__ import annotations

import threading
from collections.abc import Callable
from typing import Any

import viser

from wiithrow.app.calibration.versions import CalibrationFigures, side_by_side_markdown
from wiithrow.app.session import Operation, Session, SessionSnapshot
from wiithrow.app.session.library_use import calibration_note
from wiithrow.app.throws.library_compare import LibraryChoice, table_markdown
from wiithrow.app.throws.library_store import VersionInfo
from wiithrow.web.access import Role
from wiithrow.web.controls import GUEST_REASON

USE_VERSION = "Use this version"
USE_NEW = "Use the new library"
KEEP_OLD = "Keep the library in use"
#: The versions the folder lists (the newest; `wiithrow library list` has them all).
LISTED = 10
#: Why *Use this version* is disabled without a library folder.
NO_FOLDER = "no library folder: the session keeps no versions"
_ORDER = {"version": 1.0, "use": 1.1, "choose": 2.0, "keep": 2.1, "reasons": 3.0, "status": 10.0}


def version_line(v: VersionInfo) -> str:
    """One version in a line: how, throws, held-out error."""
    heldout = f", held-out {1e3 * v.heldout.mean_m:.1f} mm" if v.heldout is not None else ""
    used = "" if v.used_by_learning else ", not used"
    return f"version {v.id} ({v.how}, {v.throws} throws{heldout}{used})"


def learning_line(s: SessionSnapshot) -> str:
    """What the learning did with the last throw (module docstring)."""
    state = "on" if s.learning else "off (measured throws do not join)"
    last = next((r for r in reversed(s.history) if r.learned is not None), None)
    if last is None:
        return f"**The learning**: {state}; no throw has joined yet"
    learned = last.learned or {}
    if "error" in learned:
        did = f"refused: {learned['error']}"
    elif not learned.get("used", True):
        did = f"kept as version {learned.get('version')} but not used: {learned.get('not_used')}"
    else:
        where = f" as version {learned['version']}, in use" if learned.get("version") is not None else " (in memory)"
        did = (
            f"joined{where} (held-out error near it {1e3 * learned['heldout_m']:.1f} mm, its parent's "
            f"{1e3 * learned['parent_heldout_m']:.1f} mm)"
        )
        if learned.get("save_error"):
            did += f"; ⚠ {learned['save_error']}"
    return f"**The learning**: {state}; throw {last.index}: {did}"


def choice_text(choice: LibraryChoice) -> str:
    """The comparison waiting for the operator: the table and the verdict."""
    return (
        "**A trained library waits for your choice** (use it, or keep the library in use):\n\n"
        + table_markdown(choice.comparison)
        + f"\n\n{choice.comparison.verdict()}"
    )


def choice_dialog(client: viser.ClientHandle, choice: LibraryChoice, choose: Callable[[bool], None]) -> None:
    """The modal *Finish training* opens in `client`'s browser (module docstring)."""
    better = choice.comparison.better
    with client.gui.add_modal("The trained library against the one in use") as modal:
        client.gui.add_markdown(
            table_markdown(choice.comparison)
            + f"\n\n{choice.comparison.verdict()}."
            + ("" if better else " It is not put in use unless you choose it.")
        )
        use = client.gui.add_button(USE_NEW if better else f"{USE_NEW} anyway", color="green" if better else "orange")
        keep = client.gui.add_button(KEEP_OLD, color=None if better else "green")

    @use.on_click
    def _(_event: viser.GuiEvent) -> None:
        modal.close()
        choose(True)

    @keep.on_click
    def _(_event: viser.GuiEvent) -> None:
        modal.close()
        choose(False)


class LibraryInputs:
    """One browser's Library inputs (module docstring); a guest's disabled with `disabled_reason`."""

    def __init__(self, client: viser.ClientHandle, clicked: Callable[..., None] | None, disabled_reason: str) -> None:
        gui, off = client.gui, bool(disabled_reason)
        self.operator = not off

        def hint(text: str) -> str:
            return f"{text} ({disabled_reason})" if off else text

        self.version = gui.add_number(
            "Version", 1, min=1, step=1, order=_ORDER["version"], disabled=off,
            hint=hint("the library folder's version to put in use (the list above)"),
        )  # fmt: skip
        self.buttons = {
            USE_VERSION: gui.add_button(USE_VERSION, order=_ORDER["use"], disabled=off, hint=hint("go back to it")),
            USE_NEW: gui.add_button(USE_NEW, order=_ORDER["choose"], disabled=off, hint=hint("after Finish training")),
            KEEP_OLD: gui.add_button(KEEP_OLD, order=_ORDER["keep"], disabled=off, hint=hint("after Finish training")),
        }
        self.reasons = gui.add_markdown(disabled_reason and f"Not now: {disabled_reason}", order=_ORDER["reasons"])
        if clicked is None or off:
            return
        self.buttons[USE_VERSION].on_click(lambda event: clicked(event, Operation.LIBRARY_USE, int(self.version.value)))
        self.buttons[USE_NEW].on_click(lambda event: clicked(event, Operation.LIBRARY_CHOOSE, True))
        self.buttons[KEEP_OLD].on_click(lambda event: clicked(event, Operation.LIBRARY_CHOOSE, False))

    def show(self, states: dict[str, str]) -> None:
        """Each button disabled with its reason (`states`: label -> "" or why not), in its hint and
        in the visible line."""
        if not self.operator:
            return
        for name, button in self.buttons.items():
            why = states.get(name, "")
            if button.disabled != bool(why):
                button.disabled = bool(why)
        if self.version.disabled != bool(states.get(USE_VERSION)):
            self.version.disabled = bool(states.get(USE_VERSION))
        lines = [f"*{name}*: {why}" for name, why in states.items() if why]
        text = "Not now: " + " · ".join(lines) if lines else ""
        if self.reasons.content != text:
            self.reasons.content = text


class LibraryPanel:
    """The Library folder (module docstring), in the server's shared GUI."""

    def __init__(
        self,
        server: viser.ViserServer,
        session: Session,
        accept: Callable[[viser.ClientHandle | None, Operation], bool],
        runner: Any,
        *,
        guest_reason: str = GUEST_REASON,
    ) -> None:
        self.server, self.session, self.accept, self.runner = server, session, accept, runner
        self.guest_reason = guest_reason
        with server.gui.add_folder("Library", expand_by_default=False) as self.folder:
            self.status = server.gui.add_markdown("", order=_ORDER["status"])
        self._lock = threading.Lock()
        self._inputs: dict[int, LibraryInputs] = {}
        self._key: Any = None
        self._text = ""
        self._calibrations: list[CalibrationFigures] = []  # the one in use last, the one it replaced before
        server.on_client_disconnect(self._left)

    # -- clients ---------------------------------------------------------------------------------------

    def add_client(self, client: viser.ClientHandle, role: Role) -> LibraryInputs:
        operator = role is Role.OPERATOR
        with self.folder:
            inputs = LibraryInputs(client, self._clicked if operator else None, "" if operator else self.guest_reason)
        with self._lock:
            self._inputs[client.client_id] = inputs
        inputs.show(self.states())
        return inputs

    async def _left(self, client: viser.ClientHandle) -> None:
        with self._lock:
            self._inputs.pop(client.client_id, None)

    def states(self) -> dict[str, str]:
        """Each button's reason for an operator ("" when it may be pressed)."""
        refusals = self.session.refusals((Operation.LIBRARY_USE, Operation.LIBRARY_CHOOSE))
        use = refusals[Operation.LIBRARY_USE] or ("" if self.session.library_store is not None else NO_FOLDER)
        choose = refusals[Operation.LIBRARY_CHOOSE] or ""
        return {USE_VERSION: use, USE_NEW: choose, KEEP_OLD: choose}

    # -- what is shown -----------------------------------------------------------------------------------

    def show(self, s: SessionSnapshot) -> None:
        """The folder as `s` has it (called on a session change)."""
        self._follow_calibration()
        text = self.text(s)
        if text != self._text:
            self._text = text
            self.status.content = text
        states = self.states()
        with self._lock:
            inputs = list(self._inputs.values())
        for i in inputs:
            i.show(states)

    def _follow_calibration(self) -> None:
        calibration = self.session.world.calibration
        if calibration is None:
            return
        figures = CalibrationFigures.of(calibration)
        if not self._calibrations or self._calibrations[0].fingerprint != figures.fingerprint:
            self._calibrations = [figures, *self._calibrations[:1]]

    def text(self, s: SessionSnapshot) -> str:
        session = self.session
        store, version = session.library_store, session.library_version
        where = f" of {store.folder}" if store is not None else " (no library folder: nothing is versioned)"
        in_use = version_line(version) if version is not None else "the shipped library (not a version)"
        lines = [f"**In use**: {in_use}{where}", learning_line(s)]
        if s.library_choice is not None:
            lines.append(choice_text(s.library_choice))
        if self._calibrations:
            new, *old = self._calibrations
            note = calibration_note(version, new.fingerprint)
            lines.append("**Calibration in use**" + (f" (⚠ {note})" if note else "") + ":")
            lines.append(side_by_side_markdown(new, old[0] if old else None))
        if store is not None:
            versions = store.versions()
            newest = versions[-LISTED:][::-1]
            rows = [f"| {v.id} | {v.time[:19]} | {v.how} ({v.by}) | {v.throws} | "
                    f"{'' if v.heldout is None else f'{1e3 * v.heldout.mean_m:.1f}'} | "
                    f"{'in use' if version is not None and v.id == version.id else ('not used' if not v.used_by_learning else '')} |"
                    for v in newest if not v.broken]  # fmt: skip
            lines.append(f"**Versions** (the newest {len(newest)} of {len(versions)}):")
            lines.append(
                "\n".join(
                    ["| version | made (UTC) | how | throws | held-out mm | |", "|---|---|---|---|---|---|", *rows]
                )
            )
        return "\n\n".join(lines)

    # -- what the buttons do -----------------------------------------------------------------------------

    def _clicked(self, event: viser.GuiEvent, op: Operation, argument: Any) -> None:
        client = event.client
        if not self.accept(client, op):
            return
        if op is Operation.LIBRARY_USE:
            self.runner.start(
                op,
                lambda: self.session.use_version(int(argument)),
                client=client,
                done=lambda info: ("Library", f"version {info.id} in use"),
            )
        else:
            self.choose(client, bool(argument))

    def choose(self, client: viser.ClientHandle | None, use: bool) -> None:
        """The operator's choice after *Finish training* (the dialog's or the folder's buttons)."""
        if not self.accept(client, Operation.LIBRARY_CHOOSE):
            return
        self.runner.start(
            Operation.LIBRARY_CHOOSE,
            lambda: self.session.choose_trained_library(use),
            client=client,
            done=lambda line: ("Library", line),
        )

    def open_choice(self, client: viser.ClientHandle | None) -> None:
        """Open the choice dialog in `client`'s browser, if a trained library waits."""
        choice = self.session.snapshot().library_choice
        if client is None or choice is None:
            return
        choice_dialog(client, choice, lambda use: self.choose(client, use))
