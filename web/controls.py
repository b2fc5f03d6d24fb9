"""Each browser's own controls: the buttons an operator presses and a guest sees disabled.

Owns `ClientControls`, built for every client that connects (viser's client-scoped GUI, nested in
the shared panel's folders, `wiithrow.web.panels.Panels`): Poses and Calibrate, the residual
scale, Track target, Preview throw, Throw and Home, Record (when the dashboard records:
`wiithrow.web.recording_toggle`), and for an operator in simulation the target's drag handle; and the confirmation a throw asks for in the browser that pressed Throw
(`confirm_throw`). An operator's buttons follow `button_states` (what the session allows now,
a pure function of its snapshot, tested without a browser); a guest's are disabled, each saying
why (`GUEST_REASON`), and a guest gets no drag handle. Stop is not here: it is the shared panel's,
the same button for everyone. What a click does is the caller's (`Callbacks`); the server checks
the clicking client's role again before it starts anything (`wiithrow.web.server`).
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any, Literal

import numpy as np
import viser
from numpy.typing import NDArray

from wiithrow.app.session import SessionSnapshot, ThrowPreview
from wiithrow.web.access import Role
from wiithrow.web.wand_panel import WandInputs

#: Why a guest's buttons are disabled (their hint says it).
GUEST_REASON = "view only: open the operator's link (the address printed at start, with ?token=) to operate"
#: Why the arm's buttons are disabled when the arm has no driver, and why Throw is on hardware.
NO_ARM = "no arm driver: the arm is parked"
NO_REAL_THROW = "no gripper driver: the ball cannot be let go (settings gripper_driver)"
#: Operations the buttons start, in `button_states`' keys.
OPERATIONS = ("calibrate", "home", "track", "preview", "throw", "measure")
#: The operation buttons: label, icon (a `viser.Icon`, typed by a private module of viser's), what it
#: does (its hint), colour.
BUTTONS: dict[str, tuple[str, Any, str, Literal["orange"] | None]] = {
    "calibrate": ("Calibrate", viser.Icon.SCAN, "the arm shows the rig its LED at each pose", None),
    "track": (
        "Track target",
        viser.Icon.CURRENT_LOCATION,
        "turn joint 1 until the target lies in the throw plane",
        None,
    ),
    "preview": ("Preview throw", viser.Icon.EYE, "plan and validate the throw; the ghost arm shows it", None),
    "throw": ("Throw", viser.Icon.BALL_TENNIS, "execute the preview (asks for confirmation)", "orange"),
    "home": ("Home", viser.Icon.ARROW_BACK_UP, "move the arm back to its home pose (after a Stop, say)", None),
    "measure": (
        "Measure landing",
        viser.Icon.RULER_MEASURE,
        "the rig measures the IR marker put where the last throw's ball first came down (target covered)",
        None,
    ),
}
#: Place of each control among the shared elements of its folder (`Panels` uses the others).
ORDER = {
    "poses": 1.0,
    "calibrate": 2.0,
    "residual": 5.0,
    "track": 1.0,
    "preview": 2.0,
    "throw": 3.0,
    "measure": 3.5,
    "home": 4.0,
    "record": 6.0,
}
#: The Record toggle's label and hint while stopped and while recording.
RECORD = ("Record", "record the session to an MCAP file (replay: `wiithrow replay`)")
RECORDING = ("Stop recording", "recording the session; press to close the file")


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


def button_states(
    s: SessionSnapshot,
    *,
    calibrated: bool,
    target_moved: bool,
    arm_connected: bool = True,
    can_throw: bool = True,
    calibration_refused: str = "",
) -> dict[str, str]:
    """For each operation button, "" if it may be pressed now, else why not (shown as its hint)."""
    busy = f"{s.operation or 'an operation'} is running" if s.busy else ""
    states = dict.fromkeys(OPERATIONS, busy)
    if not busy and not arm_connected:
        return dict.fromkeys(states, NO_ARM)
    if not busy:
        if not calibrated:
            states["track"] = "calibrate first"
        aligned = s.alignment is not None and s.alignment.converged
        if not aligned:
            states["preview"] = "track the target first" if calibrated else "calibrate first"
        elif target_moved:
            states["preview"] = "the target moved: track it again"
        if s.preview is None:
            states["throw"] = "preview the throw first"
        elif not can_throw:
            states["throw"] = NO_REAL_THROW
        if calibration_refused:
            states["calibrate"] = calibration_refused
        if not s.history:
            states["measure"] = "throw first: the last throw's landing is measured"
        elif not calibrated:
            states["measure"] = "calibrate first"
    return states


class ClientControls:
    """One client's controls (see the module docstring). Built on viser's event loop when the
    client connects; `show` and `follow_target` are called by the refresh thread."""

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
    ) -> None:
        self.client = client
        self.role = role
        operator = role is Role.OPERATOR
        gui = client.gui
        calibration, throw = folders
        guest = not operator

        def hint(text: str) -> str:
            return f"{text} ({GUEST_REASON})" if guest else text

        def button(name: str) -> viser.GuiButtonHandle:
            label, icon, what, color = BUTTONS[name]
            return gui.add_button(label, color=color, icon=icon, hint=hint(what), order=ORDER[name], disabled=guest)

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
            self.calibrate = button("calibrate")
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
                button(n) for n in ("track", "preview", "throw", "measure", "home")
            )
        self.wand: WandInputs | None = None
        if wand is not None:  # the wand calibration's inputs (`wiithrow.web.wand_panel`)
            wand_folder, frames = wand
            with wand_folder:
                self.wand = WandInputs(
                    gui, callbacks.wand, frames=frames, disabled_reason=GUEST_REASON if guest else ""
                )
        self._buttons = {
            "calibrate": self.calibrate,
            "home": self.home,
            "track": self.track,
            "preview": self.preview,
            "throw": self.throw,
            "measure": self.measure,
        }
        self._hints = {name: BUTTONS[name][2] for name in self._buttons}
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
                "/target_handle", scale=0.35, disable_rotations=True, depth_test=False, line_width=3.0
            )
            self.follow_target(target)
            handle = self.handle

            @handle.on_update
            def _(event: viser.TransformControlsEvent) -> None:
                # callbacks run in a thread pool, possibly out of order: use the handle's latest pose
                self._last_drag = time.monotonic()
                callbacks.target_moved(np.asarray(handle.position, dtype=float), event.client)

    def show(self, states: dict[str, str]) -> None:
        """An operator's buttons as `button_states` says (a guest's stay disabled)."""
        if self.role is not Role.OPERATOR:
            return
        for name, why in states.items():
            button = self._buttons[name]
            if button.disabled != bool(why):
                button.disabled = bool(why)
            hint = f"{self._hints[name]} (now: {why})" if why else self._hints[name]
            if button.hint != hint:
                button.hint = hint

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
        """Move the drag handle to where the target is, unless this client is dragging it."""
        if self.handle is None or not np.isfinite(position).all() or time.monotonic() - self._last_drag < 0.5:
            return
        if not np.allclose(position, self._handle_at, atol=1e-3):
            self.handle.position = position
            self._handle_at = np.array(position, dtype=float)


def confirm_throw(client: viser.ClientHandle, p: ThrowPreview, throw_now: Callable[[], None]) -> None:
    """A modal in `client`'s browser: what the throw will do; "Throw now" calls `throw_now`."""
    worst = int(np.argmax(p.speed_ratio))
    with client.gui.add_modal(f"Throw preview {p.id}?") as modal:
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
