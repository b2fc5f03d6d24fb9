"""The dashboard: assembles the viser server, the scene, the panels and the operation runner.

Owns `Dashboard`, which
* observes the session (`Session.subscribe` marks it dirty; `Session.snapshot` is read once per
  refresh) and the world it exposes (`wiithrow.web.live.read_live_state`; the rig only when its
  lock is free, `read_rig`: a refresh never waits for a poll);
* refreshes the browsers from one thread at up to `rate_hz` (20 Hz by default), all changes of
  one refresh batched in one `server.atomic()` block, each refresh timed by a `CostMeter`; camera
  images at `camera_rate_hz`, marker trails at 10 Hz; nothing is sent that is already drawn. The
  rate adapts (`AdaptiveRate`) so that refreshing plus sending to every client stays within
  `budget_ms` of CPU per 100 Hz tracking frame. The tracking loop runs in the session's own
  thread and never waits for the dashboard: each refresh starts 3 ms after a poll of the rig ends
  (`wiithrow.web.poll_phase.PollPhase`), and while it serves, the interpreter's switch interval is
  0.5 ms (`wiithrow.web.throttle.SwitchInterval`: the rig's threads wait less for the refresh's);
* lets in only who belongs, within per-connection limits (`wiithrow.web.access`, `.limits`,
  installed in viser's handshake by `wiithrow.web.handshake`; bound to 127.0.0.1 unless told
  otherwise): a foreign Host or Origin gets 403, the token makes an operator, anyone else is a
  guest; each browser gets its own controls (`wiithrow.web.controls`; a guest's say why not);
* shows the Training panel (`wiithrow.web.training_panel`; its clicks are checked by `_accept`);
* turns an operator's clicks into session operations (`wiithrow.web.operations.OperationRunner`:
  worker threads, one operation at a time), a throw after a confirmation; every click is checked
  again here (`_accept`): a guest's starts nothing, and one whose precondition fails
  (`Session.refusal`, which also disabled its button) is refused with that text. Stop is
  everyone's: each press calls `Session.stop(by=...)` at once, naming who pressed it (the
  operator, a guest); a burst of presses notifies once: every browser when something ran, only
  the one that pressed when nothing did;
* in each browser's page: its scene's lighting (`wiithrow.web.light_scene`: plain when it renders
  in software, or at its operator's *Light scene* switch) and a dialog's overlay that never takes
  Stop's click (`wiithrow.web.page_script`).
"""

from __future__ import annotations

import contextlib
import dataclasses
import threading
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Literal
from urllib.parse import quote

import numpy as np
import viser

from wiithrow.app.calibration.robot import DEFAULT_POSES
from wiithrow.app.calibration.wand import parse_frame
from wiithrow.app.errors import AppError
from wiithrow.app.session import (
    Event,
    Operation,
    Session,
    SessionSnapshot,
    ThrowPreview,
    ThrowRecord,
    busy_reason,
    throw_outcome,
)
from wiithrow.app.studies.figures.positions import actual_vs_calculated
from wiithrow.fault_lines import FaultLines
from wiithrow.web.access import AccessPolicy, RefusalLog, Role, Token, new_token
from wiithrow.web.analysis import Analysis
from wiithrow.web.clients import Clients
from wiithrow.web.controls import Callbacks, ClientControls, button_states, confirm_throw, label
from wiithrow.web.derived_figures import DerivedFigures
from wiithrow.web.drawings import camera_poses, preview_drawing, speed_ratios
from wiithrow.web.handshake import Gatekeeper, Limits, start_viser, stop_viser
from wiithrow.web.light_scene import LightScene
from wiithrow.web.live import LiveState, RigReading, read_live_state, read_rig
from wiithrow.web.operations import OperationRunner
from wiithrow.web.page_script import STOP_NEVER_COVERED, run_in_page
from wiithrow.web.panels import Panels, machine_words
from wiithrow.web.poll_phase import PollPhase
from wiithrow.web.scene import PreviewDrawing, SceneView
from wiithrow.web.throttle import (
    AdaptiveRate,
    CostMeter,
    Every,
    SwitchInterval,
    Ticker,
    sender_thread,
    thread_cpu_s,
)
from wiithrow.web.training_panel import TrainingPanel
from wiithrow.web.wand_panel import WandPanel

#: Colours of the notifications the dashboard sends.
Color = Literal["blue", "green", "yellow", "red"]

DEFAULT_HOST = "127.0.0.1"
DEFAULT_PORT = 8080


@dataclass
class _ThrowInFlight:
    t0: float  # world clock when the throw operation started
    preview: ThrowPreview | None
    history_before: int
    revision: int  # the session's revision when it started
    drawing: PreviewDrawing | None = None


def result_label(record: ThrowRecord) -> str:
    """The scene's label of a throw's landing: its number and its outcome (`throw_outcome`: the one
    error figure, in one unit, and who measured it), the same words as the table's and the status's."""
    return f"throw {record.index}: {throw_outcome(record)}"


class Dashboard:
    """The operator's dashboard for one session (see the module docstring)."""

    def __init__(
        self,
        session: Session,
        *,
        host: str = DEFAULT_HOST,
        port: int = DEFAULT_PORT,
        token: Token | None = None,
        allow_hosts: Sequence[str] = (),
        rate_hz: float = 20.0,
        camera_rate_hz: float = 4.0,
        budget_ms: float = 1.0,
        default_poses: int = DEFAULT_POSES,
        derived_figures: bool = True,
        analysis_process: bool = True,
        verbose: bool = False,
        limits: Limits | None = None,
        plain_scene: bool = False,
    ) -> None:
        self.session = session
        self.world = world = session.world
        self.host = host
        self.rate = AdaptiveRate(rate_hz, budget_ms=budget_ms)
        self.access = AccessPolicy(token or new_token(), host, tuple(allow_hosts))
        self.refusals = RefusalLog()
        self._gatekeeper = Gatekeeper(self.access, self.refusals, limits)
        self.server = start_viser(self._gatekeeper, host=host, port=port, label="wiithrow", verbose=verbose)
        self.server.gui.set_panel_label("wiithrow")
        self.meter = CostMeter()
        self.runner = OperationRunner(session, self.notify)
        self.analysis = Analysis(use_process=analysis_process)
        self.simulated = bool(world.simulated)
        self.figures = DerivedFigures(self.analysis, world, enabled=derived_figures)
        self.scene = SceneView(
            self.server, str(world.arm_model.urdf_path), world.arm_model.joint_names, plain=plain_scene
        )
        self.panels = Panels(
            self.server,
            world.camera_names(),
            self._on_stop,
            world_title=world.title,
            still_progress=plain_scene,
            where=machine_words(
                world.title, world.arm_model.spec.description if world.arm_model.spec else world.arm_model.name
            ),
        )
        self._gatekeeper.stop_uuid = self.panels.stop._impl.uuid  # guests may press Stop (a private attribute)
        self.default_poses = int(default_poses)
        self.plain_scene = plain_scene
        #: Each connected browser's scene lighting (`wiithrow.web.light_scene`), by client id.
        self.light_scenes: dict[int, LightScene] = {}
        self._callbacks = Callbacks(
            calibrate=self._on_calibrate,
            track=self._on_track,
            home=self._on_home,
            preview=self._on_preview,
            throw=self._on_throw,
            measure=self._on_measure,
            residual_scale=self._on_residual_scale,
            target_moved=self._target_moved,
            wand=self._on_wand,
        )
        #: What each operation button shows an operator now: "" if it may be pressed, else why not.
        self.states: dict[Operation, str] = {}
        self.stops = 0  # Stop presses, from any client
        self.stop_seen_at: float | None = None  # when the last press reached the server (`time.time()`)
        self.stop_notices = 0  # Stop notifications sent: one per burst of presses
        with contextlib.suppress(Exception):
            self.scene.set_trained_area(np.asarray(session.planner.area.vertices, float))
        with self.server.gui.add_folder("Wand", expand_by_default=False) as self.wand_folder:
            self.wand = WandPanel(self.server.gui, world.camera_names())
        self.wand_frames = ("camera", "robot") if world.arm_connected else ("camera",)
        self.training = TrainingPanel(self.server, session, self.scene, self._accept, self.runner)  # resumes
        self._camera_every = Every(1.0 / camera_rate_hz)
        self._wand_every = Every(0.5)
        self._trail_every = Every(0.1)
        # each operator's drag handle follows the target at 4 Hz (a message per operator each time)
        self._target_every = Every(0.25)
        self._revision = -1
        self._calibration_events, self._calibration_seen = 0, (-1, -1)  # (rig revision, session events)
        self._preview_seen: int | None = None
        self._drawing: PreviewDrawing | None = None
        self._throwing: _ThrowInFlight | None = None
        self._result_shown: int | None = None  # the throw whose landing the scene shows, with its label
        self._worst: list[tuple[int, float]] = []
        #: What the last refresh read of the rig (`read_rig`: never waits for a polling rig).
        self.rig_reading: RigReading | None = None
        self._scale_request: float | None = None
        self._last_refusal = -np.inf
        self._stop = threading.Event()
        self._paused = threading.Event()
        self._thread: threading.Thread | None = None
        #: The rig's polls the refresh follows (`wiithrow.web.poll_phase`), while the refresh thread runs.
        self.poll_phase: PollPhase | None = None
        self.switch_interval = SwitchInterval()  # while serving: the rig's threads wait <= 0.5 ms for the refresh's
        self.refresh_errors = 0
        #: The refresh's faults, one stderr line each (a step that raises is skipped, the rest drawn).
        self.refresh_faults = FaultLines("dashboard refresh")
        self._live: LiveState | None = None
        self._arm_fault: str | None = None
        session.subscribe(self._on_event)
        self.clients = Clients(self.server, self._build_controls, self.refusals, self.notify)
        self.clients.on_left = self._client_left

    # -- lifecycle ----------------------------------------------------------------------------------------

    @property
    def port(self) -> int:
        return int(self.server.get_port())

    @property
    def url(self) -> str:
        """The guests' address (sees everything, moves nothing)."""
        host = self.host if self.host not in ("0.0.0.0", "::") else "127.0.0.1"
        if ":" in host:
            host = f"[{host}]"
        return f"http://{host}:{self.port}/"

    @property
    def operator_url(self) -> str:
        """The operator's address: `url` with the token (print it once, at start, and nowhere else)."""
        return f"{self.url}?token={quote(self.access.token.value, safe='')}"

    def start(self) -> None:
        """Start the session's rig loop (if not running) and the refresh thread."""
        self.switch_interval.apply()
        self.session.start()
        if self._thread is None:
            self._stop.clear()
            self.poll_phase = PollPhase(self.world.rig)
            self._thread = threading.Thread(target=self._loop, name="wiithrow-web-refresh", daemon=True)
            self._thread.start()

    def close(self) -> None:
        """Stop refreshing and serving (the session is the caller's to stop and close)."""
        self._stop.set()
        if self._thread is not None:
            self._thread.join(timeout=2.0)
            self._thread = None
        if self.poll_phase is not None:
            self.poll_phase.close()
            self.poll_phase = None
        self.analysis.close()
        self._gatekeeper.closing = True  # (a flooding guest's backlog is not read at its rate limit)
        stop_viser(self.server)
        self.switch_interval.restore()

    def add_recording(self, record: Callable[[viser.GuiEvent], None], recording: Callable[[], bool]) -> None:
        """The Record toggle for clients that connect from now on: `record(event)` on a click,
        `recording()` whether the session is being recorded now (`wiithrow.web.recording_toggle`)."""
        self._callbacks = dataclasses.replace(self._callbacks, record=record, recording=recording)

    @property
    def figures_pending(self) -> int:
        """Derived figures (error curve, mono vs stereo) still being computed."""
        return len(self.figures)

    def pause(self, paused: bool = True) -> None:
        """Stop (or resume) refreshing the browsers; the bench measures the baseline this way."""
        if paused:
            self._paused.set()
        else:
            self._paused.clear()

    @property
    def rate_hz(self) -> float:
        """The refresh rate now (adapted to the CPU budget, see `wiithrow.web.throttle.AdaptiveRate`)."""
        return self.rate.rate_hz

    def _loop(self) -> None:
        ticker = Ticker(self.rate.rate_hz)
        sender = sender_thread(self.server)
        adapt = Every(1.0)
        adapt.due()
        last = (self.meter.count, self.meter.total_cpu_s, thread_cpu_s(sender))
        phase = self.poll_phase
        while ticker.wait(self._stop):
            if self._paused.is_set():
                last = (self.meter.count, self.meter.total_cpu_s, thread_cpu_s(sender))
                continue
            if phase is not None:
                phase.wait()  # draw between two polls of the rig, not during one
                if self._stop.is_set():  # (closed meanwhile: the server may be stopping)
                    break
            try:
                self.refresh()
            except Exception as exc:  # a drawing bug must not stop the dashboard: one line per kind
                self.refresh_errors += 1
                self.refresh_faults.report(exc, "the dashboard goes on")
            if adapt.due():  # what the last second of updates cost, sending to the clients included
                now = (self.meter.count, self.meter.total_cpu_s, thread_cpu_s(sender))
                ticker.set_rate(self.rate.observe(now[1] - last[1] + now[2] - last[2], now[0] - last[0]))
                last = now

    # -- notifications ----------------------------------------------------------------------------------

    def notify(self, client: viser.ClientHandle | None, title: str, body: str, color: Color = "blue") -> None:
        """A notification to `client`, or to every connected client when None."""
        clients = [client] if client is not None else list(self.server.get_clients().values())
        for c in clients:
            try:
                c.add_notification(title, body, auto_close_seconds=12.0 if color == "red" else 6.0, color=color)
            except Exception:  # the client went away
                pass

    # -- session events and the refresh ---------------------------------------------------------------

    def _on_event(self, event: Event) -> None:
        """Called in the session's (worker) thread: record when a throw starts, nothing slow."""
        self._calibration_events += event is Event.CALIBRATION  # the session's and the rig's calibration are set
        if event is Event.OPERATION and self.session.operation is Operation.THROW and self._throwing is None:
            self._throwing = _ThrowInFlight(
                self.world.clock.now(),
                self.session.preview,
                len(self.session.history),
                self.session.snapshot().revision,
            )

    def refresh(self) -> None:
        """One update of every browser (called by the refresh thread; public for the bench)."""
        with self.meter.measure():
            self.rig_reading = read_rig(self.world.rig, self.rig_reading)
            live = self._live = read_live_state(self.session, self.rig_reading, self._live)
            step = self.refresh_faults.guard  # a step that raises is one line; the others still draw
            with self.server.atomic():
                self._tell_arm_fault(live.arm_fault)
                with step("the dashboard goes on"):
                    self.scene.update_arm(live.q, live.link1, fault=live.arm_fault)
                with step("the dashboard goes on"):
                    self.scene.update_markers(live.t, live.marker_ids, live.markers, trails=self._trail_every.due())
                self.scene.update_target(live.target)
                if self._target_every.due():
                    self._follow_target()
                if self._camera_every.due():
                    self.panels.cameras.update(live.dots, live.camera_fresh)
                    self.panels.show_hand(live.hand_opening, live.hand_holding)
                if self._wand_every.due():
                    s = live.session
                    self.wand.show(s.wand, s.wand_progress, s.operation is Operation.CALIBRATE_WAND)
                if live.session.revision != self._revision:
                    self._revision = live.session.revision
                    self._apply_session(live)
                self.figures.apply(self.panels, self.notify)
                if self._scale_request is not None:
                    self.scene.residual_scale, self._scale_request = self._scale_request, None
                    self._draw_calibration(live.session)
                self.scene.animate_preview()
                self._animate_throw(live)

    def _tell_arm_fault(self, fault: str | None) -> None:
        """A new fault of the arm's state: one line on stderr and a notification to every browser."""
        if fault == self._arm_fault:
            return
        self._arm_fault = fault
        if fault is not None:
            self.refresh_faults.tell(f"the arm's state cannot be read: {fault}", "the scene shows its last known pose")
            self.notify(None, "Arm state unreadable", f"{fault}: the arm is drawn at its last known pose", "red")

    def _apply_session(self, live: LiveState) -> None:
        s = live.session
        if (now := (self.world.rig.calibration_revision, self._calibration_events)) != self._calibration_seen:
            self._calibration_seen = now
            self.scene.set_cameras(camera_poses(self.world))
            self._draw_calibration(s)
            self.figures.start(s)
        # the throw that was running ended
        th = self._throwing
        if th is not None and s.revision > th.revision and s.operation is not Operation.THROW:
            self._throwing = None
            if len(s.history) > th.history_before:
                r = s.history[-1]
                ex = r.execution
                self._result_shown = r.index
                self.scene.set_throw_result(ex.flight_base, ex.landing_base, result_label(r))
                self.scene.show_ball(ex.landing_base)
            else:
                self.scene.show_ball(None)
        elif th is None and s.history and s.history[-1].index == self._result_shown:
            self.scene.set_result_label(result_label(s.history[-1]))  # its landing measured anew
        # the preview
        if s.preview is not None and s.preview.id != self._preview_seen:
            self._preview_seen = s.preview.id
            self._drawing = preview_drawing(s.preview, self.world)
            self.scene.set_preview(self._drawing)
            self.scene.set_throw_result(None, None)
            self._result_shown = None
            self.scene.show_ball(None)
            self.panels.show_preview_speeds(*speed_ratios(s.preview))
        elif s.preview is None and self._preview_seen is not None:
            self._preview_seen = None
            throwing = self._throwing is not None
            self.scene.set_preview(None, keep_arc=throwing)
            if not throwing:
                self.panels.show_preview_speeds(None, None)
        calibrated = self.world.calibration is not None
        self.panels.update_session(s, calibrated=calibrated, worst=self._worst, arm_connected=self.world.arm_connected)
        self.states = button_states(self.session)
        for controls in self.clients.controls():
            controls.show(self.states)
        self.training.show(s)

    def _draw_calibration(self, s: SessionSnapshot) -> None:
        c = s.calibration
        if c is None or len(c.data) == 0:
            self._worst = []
            self.scene.set_calibration_points(None, None)
            return
        calculated = actual_vs_calculated(c.calibration, c.data.positions, c.data.image).calculated
        self._worst = [(int(i), float(c.loo.errors[i])) for i in c.loo.worst(3)]
        self.scene.set_calibration_points(c.data.positions, calculated, self._worst)

    def _animate_throw(self, live: LiveState) -> None:
        th = self._throwing
        if th is None or live.session.operation is not Operation.THROW:
            return
        if live.ball is not None:  # the world knows where the ball is (MuJoCo): draw it there
            self.scene.show_ball(live.ball)
            return
        if th.drawing is None:
            if th.preview is not None and self._drawing is not None and self._drawing.id == th.preview.id:
                th.drawing = self._drawing
            self.scene.set_throw_result(None, None)
        d = th.drawing
        t = live.t - th.t0
        if d is None or t < d.release_time:
            self.scene.show_ball(live.hand_ball)
        else:
            k = min(int(np.searchsorted(d.arc_times, float(t - d.release_time), side="right")) - 1, len(d.arc) - 1)
            self.scene.show_ball(d.arc[max(k, 0)])

    # -- clients --------------------------------------------------------------------------------------------

    def _build_controls(self, client: viser.ClientHandle, role: Role) -> ClientControls:
        controls = ClientControls(
            client,
            role,
            (self.panels.calibration_folder, self.panels.throw_folder),
            self._callbacks,
            poses=self.default_poses,
            residual_scale=self.scene.residual_scale,
            target=self.scene.target_shown if self.simulated else None,
            wand=(self.wand_folder, self.wand_frames),
            banner_order=self.panels.status.order + 0.5,
        )
        if self.states:
            controls.show(self.states)
        self.training.add_client(client, role)
        light = LightScene(
            client,
            self.notify,
            switch=role is Role.OPERATOR,
            plain=self.plain_scene,
            order=self.panels.world_md.order + 0.25,
        )
        self.light_scenes[client.client_id] = light
        run_in_page(client, STOP_NEVER_COVERED)  # a dialog's overlay never takes Stop's click
        light.ask_renderer()
        return controls

    def _client_left(self, client_id: int) -> None:
        self.light_scenes.pop(client_id, None)

    def _follow_target(self) -> None:
        target = self.scene.target_shown
        for controls in self.clients.controls():
            controls.follow_target(target)

    # -- what the buttons do -------------------------------------------------------------------------------

    def _on_stop(self, event: viser.GuiEvent) -> None:
        self.stop_seen_at = time.time()  # (wall clock: a browser test compares it with the page's click)
        self.stops += 1
        by = "a guest" if self.clients.role(event.client) is Role.GUEST else "the operator"
        ran = self.session.stop(by=by)
        if not self._gatekeeper.stop_burst.first():  # every press stops; a burst notifies once
            return
        self.stop_notices += 1
        if ran:
            self.notify(
                None,
                "Stop",
                f"{by[0].upper()}{by[1:]} pressed Stop: the running operation is cancelled and the arm brakes to rest",
                "red",
            )
        else:  # nothing moved: the one who pressed is told so, nobody else
            self.notify(event.client, "Stop", "nothing was running: the arm is at rest", "blue")

    def _accept(self, client: viser.ClientHandle | None, op: Operation, *, terminal: bool = False) -> bool:
        """The server's check of a click that would start `op` (`Clients.may_start`: the role, then
        `Session.refusal(op)`, the text that disabled the button)."""
        return self.clients.may_start(client, op, self.session, terminal=terminal)

    def start_calibration(self, n_poses: int, client=None) -> bool:
        """Run the robot-driven calibration in a worker thread (the Calibrate button; the demo,
        with no client)."""
        if not self._accept(client, Operation.CALIBRATE, terminal=True):
            return False
        return self.runner.start(
            Operation.CALIBRATE,
            lambda: self.session.calibrate(int(n_poses)),
            client=client,
            done=lambda r: ("Calibrated", f"{len(r.data)} poses; leave-one-out error {1e3 * r.loo.mean:.2f} mm"),
        )

    def _on_calibrate(self, event: viser.GuiEvent, n_poses: int) -> None:
        if event.client is None:  # a click comes from a client: refuse what does not
            self.clients.is_operator(None, label(Operation.CALIBRATE))
            return
        self.start_calibration(n_poses, event.client)

    def _on_wand(self, event: viser.GuiEvent, wand_length_m: float, seconds: float, frame: str) -> None:
        """Start a wand calibration (the Wand panel's Start): someone waves the wand meanwhile (in
        simulation, a simulated person). Operators only (tests call it with client None, as the
        terminal does)."""
        if not self._accept(event.client, Operation.CALIBRATE_WAND, terminal=True):
            return
        self.runner.start(
            Operation.CALIBRATE_WAND,
            lambda: self.session.calibrate_wand(seconds, wand_length_m, frame=parse_frame(frame)),
            client=event.client,
            done=lambda r: (
                "Wand calibration",
                f"wand score {r.result.quality.wand_score_percent:.2f} %, in frame {r.calibration.frame}",
            ),
        )

    def _on_track(self, event: viser.GuiEvent) -> None:
        if not self._accept(event.client, Operation.TRACK):
            return
        self.runner.start(
            Operation.TRACK,
            self.session.align,
            client=event.client,
            done=lambda a: ("Target aligned" if a.converged else f"Target not aligned ({a.status})", a.message),
        )

    def _on_home(self, event: viser.GuiEvent) -> None:
        if self._accept(event.client, Operation.HOME):
            self.runner.start(Operation.HOME, self.session.home, client=event.client)

    def _on_preview(self, event: viser.GuiEvent) -> None:
        if self._accept(event.client, Operation.PREVIEW):
            self.runner.start(Operation.PREVIEW, self.session.plan_preview, client=event.client)

    def _on_throw(self, event: viser.GuiEvent) -> None:
        """Open the confirmation modal in the browser that clicked."""
        client = event.client
        if not self._accept(client, Operation.THROW):
            return
        if self.runner.running:  # its worker started, the session not yet busy
            self.notify(client, "Busy", busy_reason(self.session.operation), "yellow")
            return
        assert client is not None  # _accept refuses a click from no client
        p = self.session.preview
        if p is None:  # gone since the check (a Stop, another browser's throw)
            self.notify(client, "No preview", "preview the throw first", "yellow")
            return

        def throw_now() -> None:
            if not self._accept(client, Operation.THROW):
                return
            self.runner.start(
                Operation.THROW,
                lambda: self.session.throw(p.id),
                client=client,
                done=lambda r: (f"Throw {r.index}", throw_outcome(r)),
            )

        confirm_throw(client, p, throw_now)

    def _on_measure(self, event: viser.GuiEvent) -> None:
        """Measure the landing marker (*Measure landing*; on hardware the operator put it down, in
        simulation the world's simulated operator puts it where the ball came down)."""
        if not self._accept(event.client, Operation.MEASURE_LANDING, terminal=True):
            return
        self.runner.start(
            Operation.MEASURE_LANDING,
            self.session.measure_landing,
            client=event.client,
            done=lambda r: (f"Throw {r.index}: landing measured", self.session.snapshot().message),
        )

    def _on_residual_scale(self, value: float) -> None:
        self._scale_request = float(value)

    def _target_moved(self, position: np.ndarray, client: viser.ClientHandle | None) -> None:
        """An operator dragged the target (tests call it with client None, as the terminal does)."""
        if client is not None and not self.clients.is_operator(client, "moving the target"):
            return
        p = np.array(position, dtype=float)
        p[2] = max(p[2], 0.0)  # not below the floor
        if np.linalg.norm(p - self.scene.target_drawn) < 1e-3:
            return  # an update that moves nothing must not cost the operator the preview
        why = self.session.refusal(Operation.MOVE_TARGET)
        if why is None:
            try:
                self.session.set_target(p)
                return
            except AppError as exc:  # an operation began meanwhile
                why = str(exc)
        now = time.monotonic()
        if now - self._last_refusal > 2.0:  # a drag sends many updates: say it once in a while
            self._last_refusal = now
            self.notify(client, "Target held", why, "yellow")
