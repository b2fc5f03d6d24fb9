"""Each browser's own controls: the buttons an operator presses and a guest sees disabled, and why.

Owns `ClientControls`, built for every client that connects (viser's client-scoped GUI, nested in
the shared panel's folders, `wiithrow.web.panels.Panels`): Poses and Calibrate, the residual
scale, Track target, Preview throw, Throw, Measure landing and Home, Record (when the dashboard
records: `wiithrow.web.recording_toggle`), the wand calibration's Start, and for an operator in
simulation the target's drag handle; and the confirmation a throw asks for in the browser that
pressed Throw (`confirm_throw`).

Every button is an `Operation`'s. Whether it may be pressed is `button_states`: the session's own
`Session.refusal(op)` (the one place each precondition is written, the same text the server
answers a refused click with), or for a guest `GUEST_REASON`. A disabled control says why in the
page, not only on hover: its hint (viser shows hints on hover) and a visible line in its folder
listing each disabled button with its reason; a guest also sees a line at the top saying that
they are a guest and how to become an operator. Stop is not here: it is the shared panel's, the
same button for everyone, never disabled. What a click does is the caller's (`Callbacks`); the
server checks the clicking client's role and the operation's refusal again before it starts
anything (`wiithrow.web.server`).
"""

from __future__ import annotations

import time
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any, Literal

import numpy as np
import viser
from numpy.typing import NDArray

from wiithrow.app.session import Operation, Session, ThrowPreview
from wiithrow.web.access import Role
from wiithrow.web.wand_panel import WandInputs

#: Why a guest's controls are disabled (their hints and the lines in the page say it).
GUEST_REASON = (
    "view only: you are a guest; to operate, open the operator's link (the address printed at start, with ?token=)"
)
#: The line at the top of a guest's page.
GUEST_BANNER = (
    "**You are a guest (view only)**: you see everything and can press Stop. To operate, open the "
    "operator's link: the address the dashboard printed at start, with `?token=`."
)
#: The operation buttons: label, icon (a `viser.Icon`, typed by a private module of viser's), what it
#: does (its hint), colour.
BUTTONS: dict[Operation, tuple[str, Any, str, Literal["orange"] | None]] = {
    Operation.CALIBRATE: ("Calibrate", viser.Icon.SCAN, "the arm shows the rig its LED at each pose", None),
    Operation.TRACK: (
        "Track target",
        viser.Icon.CURRENT_LOCATION,
        "turn joint 1 until the target lies in the throw plane",
        None,
    ),
    Operation.PREVIEW: ("Preview throw", viser.Icon.EYE, "plan and validate the throw; the ghost arm shows it", None),
    Operation.THROW: ("Throw", viser.Icon.BALL_TENNIS, "execute the preview (asks for confirmation)", "orange"),
    Operation.HOME: ("Home", viser.Icon.ARROW_BACK_UP, "move the arm back to its home pose (after a Stop, say)", None),
    Operation.MEASURE_LANDING: (
        "Measure landing",
        viser.Icon.RULER_MEASURE,
        "the rig measures the IR marker put where the last throw's ball first came down (target covered)",
        None,
    ),
}
#: The operations whose buttons `button_states` covers (the wand calibration's Start included).
BUTTON_OPERATIONS: tuple[Operation, ...] = (*BUTTONS, Operation.CALIBRATE_WAND)
#: What each folder's line of reasons covers, in the order the buttons appear.
FOLDER_OPERATIONS: dict[str, tuple[Operation, ...]] = {
    "calibration": (Operation.CALIBRATE,),
    "throw": (Operation.TRACK, Operation.PREVIEW, Operation.THROW, Operation.MEASURE_LANDING, Operation.HOME),
    "wand": (Operation.CALIBRATE_WAND,),
}
#: Place of each control among the shared elements of its folder (`Panels` uses the others).
ORDER = {
    "poses": 1.0,
    "calibrate": 2.0,
    "calibration_reasons": 2.5,
    "residual": 5.0,
    "track": 1.0,
    "preview": 2.0,
    "throw": 3.0,
    "measure": 3.5,
    "home": 4.0,
    "throw_reasons": 4.5,
    "record": 6.0,
    "wand_reasons": 4.5,
}
_BUTTON_ORDER = {
    Operation.CALIBRATE: ORDER["calibrate"],
    Operation.TRACK: ORDER["track"],
    Operation.PREVIEW: ORDER["preview"],
    Operation.THROW: ORDER["throw"],
    Operation.MEASURE_LANDING: ORDER["measure"],
    Operation.HOME: ORDER["home"],
}
#: The Record toggle's label and hint while stopped and while recording.
RECORD = ("Record", "record the session to an MCAP file (replay: `wiithrow replay`)")
RECORDING = ("Stop recording", "recording the session; press to close the file")
#: The wand calibration's Start, as a reason's line names it.
WAND_START = "Start wand calibration"


def label(op: Operation) -> str:
    """What the button of `op` is called in the page (the Training panel's are their operations'
    titles: `wiithrow.web.training_panel`)."""
    if op is Operation.CALIBRATE_WAND:
        return WAND_START
    return BUTTONS[op][0] if op in BUTTONS else op.title


@dataclass(frozen=True)
class Callbacks:
    """What the controls do: each button's gets the viser GUI event (with the client that clicked)."""

    calibrate: Callable[[viser.GuiEvent, int], None]  # with the client's number of poses
    track: Callable[[viser.GuiEvent], None]
    home: Callable[[viser.GuiEvent], None]
    preview: Callable[[viser.GuiEvent], None]
    throw: Callable[[viser.GuiEvent], None]
    measure: Callable[[viser.GuiEvent], None]
    residual_scale: Callable[[float], None]
    target_moved: Callable[[NDArray[np.float64], viser.ClientHandle | None], None]
    wand: Callable[[viser.GuiEvent, float, float, str], None] | None = None  # length (m), seconds, frame
    record: Callable[[viser.GuiEvent], None] | None = None  # the Record toggle
    recording: Callable[[], bool] | None = None  # whether the session is being recorded now


def button_states(session: Session, role: Role = Role.OPERATOR) -> dict[Operation, str]:
    """For each button's operation, "" if `role` may press it now, else why not: the session's
    `refusal` (what the server answers the click with), or `GUEST_REASON` for a guest."""
    if role is not Role.OPERATOR:
        return dict.fromkeys(BUTTON_OPERATIONS, GUEST_REASON)
    return {op: why or "" for op, why in session.refusals(BUTTON_OPERATIONS).items()}


def grouped_reasons(disabled: Iterable[tuple[str, str]]) -> str:
    """A panel's "Not now" line from (button, why) pairs: each reason once, after the buttons it
    holds back ("Not now: *Track target*, *Preview throw*: calibrate first"), in the buttons'
    order; "" if none."""
    groups: dict[str, list[str]] = {}
    for name, why in disabled:
        if why:
            groups.setdefault(why, []).append(f"*{name}*")
    return "Not now: " + " · ".join(f"{', '.join(names)}: {why}" for why, names in groups.items()) if groups else ""


def reasons_text(states: Mapping[Operation, str], ops: Sequence[Operation]) -> str:
    """The visible line of a folder: the disabled of `ops` and why, each reason once (`grouped_reasons`)."""
    return grouped_reasons((label(op), states.get(op, "")) for op in ops)


class ClientControls:
    """One client's controls (see the module docstring). Built on viser's event loop when the
    client connects; `show` and `follow_target` are called by the refresh thread. `folders`: the
    shared Calibration and Throw folders; `banner_order`: where a guest's line goes at the top."""

    def __init__(
        self,
        client: viser.ClientHandle,
        role: Role,
        folders: tuple[viser.GuiFolderHandle, viser.GuiFolderHandle],
        callbacks: Callbacks,
        *,
        poses: int,
        residual_scale: float,
        target: NDArray[np.float64] | None,
        wand: tuple[viser.GuiFolderHandle, Sequence[str]] | None = None,
        banner_order: float | None = None,
    ) -> None:
        self.client = client
        self.role = role
        operator = role is Role.OPERATOR
        gui = client.gui
        calibration, throw = folders
        guest = not operator
        first = GUEST_REASON if guest else ""

        def hint(text: str) -> str:
            return f"{text} ({GUEST_REASON})" if guest else text

        def button(op: Operation) -> viser.GuiButtonHandle:
            label, icon, what, color = BUTTONS[op]
            return gui.add_button(
                label, color=color, icon=icon, hint=hint(what), order=_BUTTON_ORDER[op], disabled=guest
            )

        def reasons(folder: str) -> viser.GuiMarkdownHandle:
            return gui.add_markdown(first, order=ORDER[f"{folder}_reasons"], visible=bool(first))

        self.banner: viser.GuiMarkdownHandle | None = None
        if guest:
            self.banner = gui.add_markdown(GUEST_BANNER, order=banner_order)
        with calibration:
            self.poses = gui.add_number(
                "Poses",
                int(poses),
                min=7,
                max=100,
                step=1,
                order=ORDER["poses"],
                disabled=guest,
                hint=hint("poses of the robot-driven calibration"),
            )
            self.calibrate = button(Operation.CALIBRATE)
            self.reasons: dict[str, viser.GuiMarkdownHandle] = {"calibration": reasons("calibration")}
            self.residual_scale = gui.add_slider(
                "Residual ×",
                min=1.0,
                max=100.0,
                step=1.0,
                initial_value=float(residual_scale),
                hint=hint("residual vectors in the scene are drawn this many times longer"),
                order=ORDER["residual"],
                disabled=guest,
            )
        with throw:
            self.track, self.preview, self.throw, self.measure, self.home = (
                button(op)
                for op in (
                    Operation.TRACK,
                    Operation.PREVIEW,
                    Operation.THROW,
                    Operation.MEASURE_LANDING,
                    Operation.HOME,
                )
            )
            self.reasons["throw"] = reasons("throw")
        self.wand: WandInputs | None = None
        if wand is not None:  # the wand calibration's inputs (`wiithrow.web.wand_panel`)
            wand_folder, frames = wand
            with wand_folder:
                self.wand = WandInputs(gui, callbacks.wand, frames=frames, disabled_reason=first)
                self.reasons["wand"] = reasons("wand")
        self._buttons: dict[Operation, viser.GuiButtonHandle] = {
            Operation.CALIBRATE: self.calibrate,
            Operation.HOME: self.home,
            Operation.TRACK: self.track,
            Operation.PREVIEW: self.preview,
            Operation.THROW: self.throw,
            Operation.MEASURE_LANDING: self.measure,
        }
        self._hints = {op: BUTTONS[op][2] for op in self._buttons}
        if self.wand is not None:
            self._buttons[Operation.CALIBRATE_WAND] = self.wand.start
            self._hints[Operation.CALIBRATE_WAND] = self.wand.start_hint
        self.record: viser.GuiButtonHandle | None = None
        if callbacks.record is not None:
            with throw:
                self.record = gui.add_button(
                    RECORD[0],
                    icon=viser.Icon.PLAYER_RECORD,
                    hint=hint(RECORD[1]),
                    order=ORDER["record"],
                    disabled=guest,
                )
            self.show_recording(callbacks.recording() if callbacks.recording is not None else False)
        self.handle: viser.TransformControlsHandle | None = None
        self._last_drag = -np.inf
        self._handle_at = np.full(3, np.nan)
        if guest:
            return
        self.calibrate.on_click(lambda event: callbacks.calibrate(event, int(self.poses.value)))
        self.track.on_click(callbacks.track)
        self.preview.on_click(callbacks.preview)
        self.throw.on_click(callbacks.throw)
        self.measure.on_click(callbacks.measure)
        self.home.on_click(callbacks.home)
        if self.record is not None and callbacks.record is not None:
            self.record.on_click(callbacks.record)
        self.residual_scale.on_update(lambda _: callbacks.residual_scale(float(self.residual_scale.value)))
        if target is not None:  # the simulated target can be dragged
            self.handle = client.scene.add_transform_controls(
                "/target_handle", scale=0.35, disable_rotations=True, depth_test=False, line_width=3.0, visible=False
            )
            self.follow_target(target)
            handle = self.handle

            @handle.on_update
            def _(event: viser.TransformControlsEvent) -> None:
                # callbacks run in a thread pool, possibly out of order: use the handle's latest pose
                self._last_drag = time.monotonic()
                callbacks.target_moved(np.asarray(handle.position, dtype=float), event.client)

    def show(self, states: Mapping[Operation, str]) -> None:
        """An operator's buttons as `button_states` says: disabled with the reason in the hint and
        in the folder's visible line (a guest's stay disabled, saying they are a guest's)."""
        if self.role is not Role.OPERATOR:
            return
        for op, button in self._buttons.items():
            why = states.get(op, "")
            if button.disabled != bool(why):
                button.disabled = bool(why)
            hint = f"{self._hints[op]} (now: {why})" if why else self._hints[op]
            if button.hint != hint:
                button.hint = hint
        for folder, line in self.reasons.items():
            ops = [op for op in FOLDER_OPERATIONS[folder] if op in self._buttons]
            text = reasons_text(states, ops)
            if line.content != text:
                line.content = text
            if line.visible != bool(text):
                line.visible = bool(text)

    def show_recording(self, active: bool) -> None:
        """The Record toggle's label: Record, or Stop recording while the session is recorded."""
        if self.record is None:
            return
        label, what = RECORDING if active else RECORD
        if self.record.label != label:
            self.record.label = label
            self.record.color = "red" if active else None
            self.record.hint = f"{what} ({GUEST_REASON})" if self.role is not Role.OPERATOR else what

    def follow_target(self, position: NDArray[np.float64]) -> None:
        """Move the drag handle to where the target is, unless this client is dragging it; hide it
        while there is no target (NaN: unlit, e.g. during a calibration), never left at the origin."""
        if self.handle is None:
            return
        shown = bool(np.isfinite(position).all())
        if self.handle.visible != shown:
            self.handle.visible = shown
        if not shown or time.monotonic() - self._last_drag < 0.5:
            return
        if not np.allclose(position, self._handle_at, atol=1e-3):
            self.handle.position = position
            self._handle_at = np.array(position, dtype=float)


def throw_title(p: ThrowPreview) -> str:
    """The confirmation's title of the throw of preview `p`: "Throw (preview 3): throw it?"."""
    return f"Throw (preview {p.id}): throw it?"


def confirm_throw(client: viser.ClientHandle, p: ThrowPreview, throw_now: Callable[[], None], title: str = "") -> None:
    """A modal in `client`'s browser, titled `title` (default: `throw_title`'s for this preview):
    what the throw will do; "Throw now" calls `throw_now`."""
    worst = int(np.argmax(p.speed_ratio))
    with client.gui.add_modal(title or throw_title(p)) as modal:
        client.gui.add_markdown(
            f"Target x {p.target_xz[0]:.3f} m, z {p.target_xz[1]:.3f} m in the throw plane; predicted landing "
            f"x {p.predicted_xz[0]:.3f} m, z {p.predicted_xz[1]:.3f} m.\n\nThe arm moves for {p.duration_s:.1f} s, "
            f"joint q{worst + 1} up to {100 * p.speed_ratio[worst]:.0f} % of its speed limit. Keep clear of the arm."
        )
        confirm = client.gui.add_button("Throw now", color="red", icon=viser.Icon.BALL_TENNIS)
        cancel = client.gui.add_button("Cancel")

    @confirm.on_click
    def _(_event: viser.GuiEvent) -> None:
        modal.close()
        throw_now()

    @cancel.on_click
    def _(_event: viser.GuiEvent) -> None:
        modal.close()
