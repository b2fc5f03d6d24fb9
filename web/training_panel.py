"""The Training panel: the paper's training procedure run from the dashboard, operators only.

Owns `TrainingPanel` (the shared part of the Training folder: the run's progress line, its
current target, the area and what bounded it, the finished library's held-out error and the area
it covers; in the scene the run's area and targets in the throw plane, and a training preview's
ghost) and `TrainingInputs` (each browser's own: the area's corners as numbers and as two
draggable handles in the throw plane, the number of throws, and the buttons Start training,
Preview training throw, Throw (training) (with a confirmation, as the Throw button), Measure
training landing, Retry throw, Skip throw, Finish training; a guest's are disabled and say why).
*Finish training* ends with the new library compared with the one in use, in a dialog in the
operator's browser, and the operator's choice: the Library folder (`wiithrow.web.library_panel`,
made here and shown with this panel) keeps the comparison and the two buttons until then.

Every button is a training step's `Operation`; whether it may be pressed is the session's
`Session.refusal(op)` (`training_states`), shown beside a disabled button in the page; a click is
checked again on the server (`accept`: the dashboard's `Clients.may_start`, the role and the
refusal) before the step runs in the dashboard's `OperationRunner`. The handles move within
`DRAG_LIMITS` (a sanity box); the arm's reach at the velocity margin bounds the area when the
run starts (`wiithrow.app.throws.training_run.reachable_area`, a few seconds of the simulated
operator's solves: too slow to follow a drag), and the page says what it changed.
"""

from __future__ import annotations

import threading
from collections.abc import Callable, Mapping
from typing import Any, Literal

import numpy as np
import viser
from numpy.typing import NDArray

from wiithrow.app.errors import AppError
from wiithrow.app.session import Operation, Session, SessionSnapshot, ThrowPreview
from wiithrow.app.session.status import ERROR_PER_M, ERROR_UNIT
from wiithrow.app.throws.training_run import DEFAULT_THROWS, MAX_THROWS, MIN_MEASURED, TrainingRun
from wiithrow.throwing import Area, training_area
from wiithrow.web.access import Role
from wiithrow.web.controls import GUEST_REASON, confirm_throw, grouped_reasons
from wiithrow.web.drawings import preview_drawing
from wiithrow.web.library_panel import LibraryPanel
from wiithrow.web.operations import OperationRunner
from wiithrow.web.scene import SceneView, polyline_segments

#: The buttons, in order: operation, icon, what it does (its hint), colour.
BUTTONS: tuple[tuple[Operation, Any, str, Literal["orange"] | None], ...] = (
    (
        Operation.TRAIN_START,
        viser.Icon.PLAYER_PLAY,
        "plan the run: the targets over the area (bounded by the arm's reach)",
        None,
    ),
    (
        Operation.TRAIN_PREVIEW,
        viser.Icon.EYE,
        "plan and validate the current training throw; the ghost arm shows it",
        None,
    ),
    (Operation.TRAIN_THROW, viser.Icon.BALL_TENNIS, "execute the training preview (asks for confirmation)", "orange"),
    (
        Operation.TRAIN_MEASURE,
        viser.Icon.RULER_MEASURE,
        "the rig measures the IR marker put where the ball first touched down: the throw's label",
        None,
    ),
    (Operation.TRAIN_RETRY, viser.Icon.REPEAT, "throw the current training throw again", None),
    (Operation.TRAIN_SKIP, viser.Icon.PLAYER_SKIP_FORWARD, "leave the current throw out of the library", None),
    (
        Operation.TRAIN_FINISH,
        viser.Icon.CHECK,
        "fit the library, check it, save it as a version and compare it with the one in use: you choose",
        None,
    ),
)
OPERATIONS: tuple[Operation, ...] = tuple(op for op, *_ in BUTTONS)
#: Where the handles may be dragged (link1 x, z, m): a sanity box; the reach is checked at Start.
DRAG_LIMITS = ((0.2, 3.0), (0.0, 1.5))
_ORDER = {"corners": 1.0, "count": 5.0, "buttons": 6.0, "reasons": 14.0, "status": 20.0}
_AREA_COLOUR = (230, 160, 40)
_PROPOSED_COLOUR = (240, 200, 120)


def training_states(session: Session, role: Role, guest_reason: str) -> dict[Operation, str]:
    """For each training button, "" if `role` may press it now, else why not (the session's refusal)."""
    if role is not Role.OPERATOR:
        return dict.fromkeys(OPERATIONS, guest_reason)
    return {op: why or "" for op, why in session.refusals(OPERATIONS).items()}


def training_text(s: SessionSnapshot) -> str:
    """The panel's shared text: the run under way, or the last finished one, or how to start."""
    run = s.training
    if run is None:
        outcome = s.training_outcome
        if outcome is not None:
            head = {
                True: "Trained library in use",
                False: "Trained library kept, not in use (the library in use stays)",
                None: "Trained library saved, waiting for your choice (the Library folder)",
            }[outcome.used]
            return f"**{head}**: {outcome.summary()}" + (f"\n\n{outcome.verdict}" if outcome.verdict else "")
        return (
            "No training running: set the area of the throw plane to train (drag its corners in the scene, or "
            f"type them) and the number of throws ({MIN_MEASURED}-{MAX_THROWS}), then press **Start training**."
        )
    lines = [f"**Training**: {run.progress_line()}", f"area {run.area}"]
    lines += [f"⚠ {note}" for note in run.notes]
    current = run.current
    if current is not None:
        t = current.target
        lines.append(f"target of this throw: x {t[0]:.3f} m, z {t[1]:.3f} m")
    lines += [f"⚠ throw {i + 1}: {t.release_warning}" for i, t in enumerate(run.throws) if t.release_warning]
    done = [(i, t, t.measured) for i, t in enumerate(run.throws) if t.measured is not None]
    if done:
        misses = ", ".join(
            f"{i + 1}: {ERROR_PER_M * np.linalg.norm(m - t.target):.1f} {ERROR_UNIT}" for i, t, m in done[-5:]
        )
        lines.append(f"measured landings from their targets: {misses}")
    return "\n\n".join(lines)


def area_ring(area: Area) -> NDArray[np.float64]:
    """(5, 3) the area's outline in link1 (y = 0: the throw plane), closed."""
    (x0, x1), (z0, z1) = area.x, area.z
    return np.array([[x0, 0, z0], [x1, 0, z0], [x1, 0, z1], [x0, 0, z1], [x0, 0, z0]], dtype=float)


class TrainingInputs:
    """One browser's training inputs and buttons (`client`'s GUI, inside the Training folder; the
    handles in its scene). A guest's are disabled with `disabled_reason`; an operator's buttons
    call `on_click(op, event, area, count)`."""

    def __init__(
        self,
        client: viser.ClientHandle,
        area: Area,
        on_click: Callable[[Operation, viser.GuiEvent, Area, int], None] | None,
        *,
        disabled_reason: str = "",
    ) -> None:
        gui = client.gui
        self.client = client
        off = bool(disabled_reason)

        def hint(text: str) -> str:
            return f"{text} ({disabled_reason})" if off else text

        (x0, x1), (z0, z1) = area.x, area.z
        corner = {
            "x min (m)": (x0, "the area's near edge: distance from joint 1's axis in the throw plane"),
            "x max (m)": (x1, "the area's far edge"),
            "z min (m)": (z0, "the area's lowest height"),
            "z max (m)": (z1, "the area's highest height"),
        }
        self.corners: list[viser.GuiNumberHandle[float]] = []
        for k, (name, (v, what)) in enumerate(corner.items()):
            self.corners.append(
                gui.add_number(
                    name,
                    round(float(v), 3),
                    min=0.0,
                    max=3.0,
                    step=0.01,
                    order=_ORDER["corners"] + k * 0.1,
                    disabled=off,
                    hint=hint(what),
                )
            )
        self.count = gui.add_number(
            "Throws", DEFAULT_THROWS, min=MIN_MEASURED, max=MAX_THROWS, step=1, order=_ORDER["count"], disabled=off,
            hint=hint("how many training throws (the paper: 25)"),
        )  # fmt: skip
        # the inputs say what a new run is: disabled, with Start's reason, while one cannot start
        self._inputs: list[tuple[viser.GuiNumberHandle[Any], str]] = [
            *zip(self.corners, (what for _, what in corner.values())),
            (self.count, "how many training throws (the paper: 25)"),
        ]
        self.buttons: dict[Operation, viser.GuiButtonHandle] = {}
        self._hints: dict[Operation, str] = {}
        for k, (op, icon, what, color) in enumerate(BUTTONS):
            self.buttons[op] = gui.add_button(
                op.title,
                icon=icon,
                color=color,
                hint=hint(what),
                order=_ORDER["buttons"] + k * 0.1,
                disabled=off,
            )
            self._hints[op] = what
        self.reasons = gui.add_markdown(disabled_reason and f"Not now: {disabled_reason}", order=_ORDER["reasons"])
        self.operator = not off
        self._handles: list[viser.TransformControlsHandle] = []
        self._proposed: Any = None
        # viser calls a number's update callbacks synchronously when the server sets its value:
        # `_syncing` keeps a handle's move from echoing back through the numbers (and the reverse)
        self._lock = threading.RLock()
        self._syncing = False
        if off or on_click is None:
            return
        for op, button in self.buttons.items():
            button.on_click(self._click(op, on_click))
        limits = (DRAG_LIMITS[0], (0.0, 0.0), DRAG_LIMITS[1])
        for name, (x, z) in (("near", (x0, z0)), ("far", (x1, z1))):
            handle = client.scene.add_transform_controls(
                f"/link1/training_corner_{name}", scale=0.2, active_axes=(True, False, True), disable_rotations=True,
                translation_limits=limits, depth_test=False, position=(x, 0.0, z),
            )  # fmt: skip
            handle.on_update(lambda _event: self._dragged())
            self._handles.append(handle)
        for number in self.corners:
            number.on_update(lambda _event: self._typed())
        self._draw()

    def _click(
        self, op: Operation, on_click: Callable[[Operation, viser.GuiEvent, Area, int], None]
    ) -> Callable[[viser.GuiEvent], None]:
        return lambda event: on_click(op, event, self.area(), int(self.count.value))

    def area(self) -> Area:
        """The area the inputs say (the corners in either order)."""
        x0, x1, z0, z1 = (float(c.value) for c in self.corners)
        return Area((min(x0, x1), max(x0, x1)), (min(z0, z1), max(z0, z1)))

    def _dragged(self) -> None:
        """A handle moved: its corner's numbers follow, and the outline."""
        with self._lock:
            if self._syncing:
                return
            self._syncing = True
            try:
                (nx, _, nz), (fx, _, fz) = (h.position for h in self._handles)
                for number, v in zip(self.corners, (nx, fx, nz, fz)):
                    if abs(float(number.value) - v) > 5e-4:
                        number.value = round(float(v), 3)  # type: ignore[misc]  # settable; viser 1.1's type says read-only
                self._draw()
            finally:
                self._syncing = False

    def _typed(self) -> None:
        """A number changed: the handles follow, and the outline."""
        with self._lock:
            if self._syncing:
                return
            self._syncing = True
            try:
                x0, x1, z0, z1 = (float(c.value) for c in self.corners)
                for handle, (x, z) in zip(self._handles, ((x0, z0), (x1, z1))):
                    if np.linalg.norm(np.asarray(handle.position)[[0, 2]] - (x, z)) > 5e-4:
                        handle.position = (x, 0.0, z)
                self._draw()
            finally:
                self._syncing = False

    def _draw(self) -> None:
        segments = polyline_segments(area_ring(self.area())).astype(np.float32)
        if self._proposed is None:
            self._proposed = self.client.scene.add_line_segments(
                "/link1/training_area_proposed", segments, _PROPOSED_COLOUR, thickness=0.004
            )
        else:
            self._proposed.points = segments

    def show(self, states: Mapping[Operation, str], running: bool) -> None:
        """Each button as `states` says (disabled with the reason in its hint and in the visible
        line), the area and count inputs as Start training; the proposed outline and the handles
        only while no run is under way (the run's outline is the shared one)."""
        if not self.operator:
            return
        for op, button in self.buttons.items():
            why = states.get(op, "")
            if button.disabled != bool(why):
                button.disabled = bool(why)
            hint = f"{self._hints[op]} (now: {why})" if why else self._hints[op]
            if button.hint != hint:
                button.hint = hint
        start = states.get(Operation.TRAIN_START, "")
        for number, what in self._inputs:
            if number.disabled != bool(start):
                number.disabled = bool(start)
            hint = f"{what} (now: {start})" if start else what
            if number.hint != hint:
                number.hint = hint
        text = grouped_reasons((op.title, states.get(op, "")) for op in OPERATIONS)
        if self.reasons.content != text:
            self.reasons.content = text
        for handle in self._handles:
            if handle.visible == running:
                handle.visible = not running
        if self._proposed is not None and self._proposed.visible == running:
            self._proposed.visible = not running


class TrainingPanel:
    """The Training folder (see the module docstring). `accept(client, op)` is the server's check
    of a click; steps run in `runner`; with `resume`, a run saved beside the session's training
    library is taken up at once (a restart)."""

    def __init__(
        self,
        server: viser.ViserServer,
        session: Session,
        scene: SceneView,
        accept: Callable[[viser.ClientHandle | None, Operation], bool],
        runner: OperationRunner,
        *,
        guest_reason: str = GUEST_REASON,
        resume: bool = True,
    ) -> None:
        self.server, self.session, self.scene = server, session, scene
        self.accept, self.runner = accept, runner
        self.guest_reason = guest_reason
        try:
            self.default_area = training_area(session.world.arm_model)
        except Exception:  # an arm without a throwing spec: the PA-10's area as a start
            self.default_area = Area((1.0, 1.6), (0.0, 0.4))
        with server.gui.add_folder("Training", expand_by_default=False) as self.folder:
            self.status = server.gui.add_markdown(training_text(session.snapshot()), order=_ORDER["status"])
        self.library = LibraryPanel(server, session, accept, runner, guest_reason=guest_reason)
        self._lock = threading.Lock()
        self._inputs: dict[int, TrainingInputs] = {}
        self._run_drawn: tuple[Any, ...] | None = None
        self._run_nodes: list[Any] = []
        self._preview_id: int | None = None
        self._text = ""
        server.on_client_disconnect(self._left)
        if resume:
            self.resume()

    def resume(self) -> None:
        """Take up a run saved beside the session's training library (a restart); a file that
        cannot be resumed is the session's message, and left as it is."""
        try:
            self.session.resume_training()
        except AppError as exc:
            self.session.tell(str(exc))
        except Exception as exc:  # a file format error: VisionError's kin
            self.session.tell(f"training not resumed: {exc}")

    # -- clients ---------------------------------------------------------------------------------------

    def add_client(self, client: viser.ClientHandle, role: Role) -> TrainingInputs:
        operator = role is Role.OPERATOR
        with self.folder:
            inputs = TrainingInputs(
                client,
                self.default_area,
                self._clicked if operator else None,
                disabled_reason="" if operator else self.guest_reason,
            )
        with self._lock:
            self._inputs[client.client_id] = inputs
        inputs.show(
            training_states(self.session, role, self.guest_reason), self.session.snapshot().training is not None
        )
        self.library.add_client(client, role)
        return inputs

    async def _left(self, client: viser.ClientHandle) -> None:
        with self._lock:
            self._inputs.pop(client.client_id, None)

    # -- what is shown -----------------------------------------------------------------------------------

    def show(self, s: SessionSnapshot) -> None:
        """The run as `s` has it: text, scene, each browser's buttons (called on a session change)."""
        text = training_text(s)
        if text != self._text:
            self._text = text
            self.status.content = text
        self._draw_run(s.training)
        self._draw_preview(s)
        states = training_states(self.session, Role.OPERATOR, self.guest_reason)
        with self._lock:
            inputs = list(self._inputs.values())
        for i in inputs:
            i.show(states, s.training is not None)
        self.library.show(s)

    def _draw_run(self, run: TrainingRun | None) -> None:
        key = None if run is None else (run.area, run.index, tuple(t.state for t in run.throws))
        if key == self._run_drawn:
            return
        self._run_drawn = key
        for node in self._run_nodes:
            node.remove()
        self._run_nodes = []
        if run is None:
            return
        scene = self.server.scene
        ring = polyline_segments(area_ring(run.area)).astype(np.float32)
        self._run_nodes.append(scene.add_line_segments("/link1/training_area", ring, _AREA_COLOUR, thickness=0.007))
        targets = np.array([[t.target[0], 0.0, t.target[1]] for t in run.throws], dtype=np.float32)
        colours = np.array(
            [(60, 200, 90) if t.state == "measured" else (120, 120, 120) if t.state == "skipped" else _AREA_COLOUR
             for t in run.throws],
            dtype=np.uint8,
        )  # fmt: skip
        if run.index is not None:
            colours[run.index] = (240, 60, 60)
        self._run_nodes.append(
            scene.add_point_cloud("/link1/training_targets", targets, colours, point_size=0.03, point_shape="circle")
        )

    def _draw_preview(self, s: SessionSnapshot) -> None:
        p = s.training_preview
        if p is not None and p.id != self._preview_id:
            self._preview_id = p.id
            self.scene.set_preview(preview_drawing(p, self.session.world))
        elif p is None and self._preview_id is not None:
            self._preview_id = None
            if s.preview is None:
                self.scene.set_preview(None, keep_arc=s.operation is Operation.TRAIN_THROW)

    # -- what the buttons do -----------------------------------------------------------------------------

    def _clicked(self, op: Operation, event: viser.GuiEvent, area: Area, count: int) -> None:
        client = event.client
        if not self.accept(client, op):
            return
        session = self.session
        if op is Operation.TRAIN_THROW:
            self._confirm(client)
            return
        steps: dict[Operation, Callable[[], Any]] = {
            Operation.TRAIN_START: lambda: session.start_training(area, count),
            Operation.TRAIN_PREVIEW: session.preview_training_throw,
            Operation.TRAIN_MEASURE: session.measure_training_landing,
            Operation.TRAIN_RETRY: session.retry_training_throw,
            Operation.TRAIN_SKIP: session.skip_training_throw,
            Operation.TRAIN_FINISH: session.finish_training,
        }
        done: Callable[[Any], tuple[str, str] | None] | None = None
        if op is Operation.TRAIN_FINISH:
            done = lambda outcome: self._finished(client, outcome)  # noqa: E731
        self.runner.start(op, steps[op], client=client, done=done)

    def _finished(self, client: viser.ClientHandle | None, outcome: Any) -> tuple[str, str]:
        """Finish training ended: the comparison's dialog in the operator's browser."""
        self.library.open_choice(client)
        return ("Trained library saved", f"{outcome.summary()}; {outcome.verdict}: use it or keep the library in use")

    def _confirm(self, client: viser.ClientHandle | None) -> None:
        p: ThrowPreview | None = self.session.snapshot().training_preview
        if client is None or p is None:
            return

        def throw_now() -> None:
            if self.accept(client, Operation.TRAIN_THROW):
                self.runner.start(Operation.TRAIN_THROW, lambda: self.session.training_throw(p.id), client=client)

        run = self.session.snapshot().training
        i = run.index if run is not None else None
        of = f" {i + 1} of {len(run.throws)}" if run is not None and i is not None else ""
        confirm_throw(client, p, throw_now, title=f"Training throw{of}: throw it?")
