"""The control panel every browser shares: Stop and what the operations show.

Owns the GUI elements shared by every connected browser (viser's server-level GUI: the same for
all, sent once), and how they show a `SessionSnapshot`:

* Stop (always visible, never disabled, for everyone: whoever sees the robot can stop it), the
  status line and the progress bar;
* Cameras: each camera's view (`wiithrow.web.camera_views`);
* Calibration: per-camera RMS, the leave-one-out error, the worst points, the
  error-against-number-of-points curve;
* Throw: the preview's numbers and the joint speeds against their limits;
* Last throws: a table (time, target, landing, error along / across / total, measured and true; a
  throw that ended early: failed, and why);
* Mono vs stereo: the comparison plot (Fig. 6).

The buttons that start operations are each browser's own (`wiithrow.web.controls`: an operator's
work, a guest's are disabled); they sit in this panel's Calibration and Throw folders, at the
places `controls.ORDER` gives them among the elements here.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence

import numpy as np
import viser
from numpy.typing import NDArray
from viser import uplot

from wiithrow.app.session import Operation, SessionSnapshot, calibration_state, throw_outcome
from wiithrow.app.session.status import ERROR_PER_M, ERROR_UNIT
from wiithrow.throwing.landing_error import LandingError
from wiithrow.web.camera_views import CameraViews

JOINT_COLORS = ("#e6194b", "#3cb44b", "#4363d8", "#f58231", "#911eb4", "#42d4f4", "#f032e6")
NO_X_TIME: dict[str, uplot.Scale] = {"x": {"time": False}}


def _fmt_xz(xz: NDArray[np.float64]) -> str:
    return f"{xz[0]:.3f}, {xz[1]:.3f}" if np.isfinite(xz).all() else "not seen"


def _fmt_error(error: LandingError | None, unknown: str = "-") -> str:
    """An error as the table's cell: along / across / total in `ERROR_UNIT` (mm; `unknown` when unknown)."""
    if error is None or not error.known:
        return unknown
    k = ERROR_PER_M
    return f"{k * error.along_m:+.1f} / {k * error.across_m:+.1f} / {k * error.total_m:.1f}"


def throws_table(s: SessionSnapshot, last: int = 8) -> str:
    """Markdown table of the last throws (newest first): the measured error and, in simulation,
    the true one, each along / across / total (`throwing.landing_error`)."""
    if not s.history:
        return "No throws yet."
    rows = [
        f"| # | time | target x, z (m) | landing x, z (m) | error along / across / total ({ERROR_UNIT}), "
        f"measured by the rig | true ({ERROR_UNIT}) |",
        "|---|---|---|---|---|---|",
    ]
    for r in reversed(s.history[-last:]):
        error, true_s = _fmt_error(r.error, "before measuring"), _fmt_error(r.true_error)
        if r.measured_again and r.error.known:
            error += " (measured anew)"
        if r.failure is not None or r.execution.release_late_s is not None:  # the reason instead of a figure
            word, _, why = throw_outcome(r).partition(" ")
            error, true_s = f"**{word}** {why}".replace("|", "/"), "-"
        rows.append(
            f"| {r.index} | {r.wall_time[11:19]} | {_fmt_xz(r.target_xz)} | {_fmt_xz(r.landing_xz)} | "
            f"{error} | {true_s} |"
        )
    return "\n".join(rows)


def calibration_summary(s: SessionSnapshot, worst: Sequence[tuple[int, float]], *, calibrated: bool) -> str:
    """Markdown: the calibration's state (the same phrase as the status line's,
    `wiithrow.app.session.status.calibration_state`), then the last robot calibration's poses,
    per-camera RMS, leave-one-out error and worst points (poses numbered from 1, as the command
    line does). `calibrated`: the rig tracks with a calibration now."""
    state = calibration_state(s, calibrated)
    if s.operation in (Operation.CALIBRATE, Operation.CALIBRATE_WAND):
        return f"**{state[0].upper()}{state[1:]}** (the page shows its progress above)."
    c = s.calibration
    if c is None and s.wand is not None:
        return "Calibrated with a wand: its figures are in **Wand**."
    if not calibrated:
        return "Not calibrated: press **Calibrate** (the arm shows the rig its LED at each pose), or use **Wand**."
    if c is None:
        return f"{state[0].upper()}{state[1:]}: press **Calibrate** to calibrate with the robot here."
    rms = ", ".join(f"cam{k} {v:.2f} px" for k, v in enumerate(c.rms_px))
    lines = [
        f"**{len(c.data)} poses** ({len(c.data.skipped)} skipped), {c.data.duration_s:.0f} s",
        f"RMS reprojection: {rms}",
        f"Leave-one-out 3D error: **{1e3 * c.loo.mean:.2f} mm**",
    ]
    if worst:
        lines.append("Worst points (leave-one-out): " + ", ".join(f"pose {i + 1}: {1e3 * e:.2f} mm" for i, e in worst))
    return "\n\n".join(lines)


def running_line(s: SessionSnapshot, where: str = "") -> str:
    """What runs and on what: "Throw 3 running on MuJoCo (simulated) Mitsubishi PA-10: <progress>"
    (`where`: the world and the arm, `machine_words`; the operation's own words when it reports no
    progress)."""
    op = s.operation
    if op is None:
        return "Working"
    name = f"Throw {s.history[-1].index + 1 if s.history else 1}" if op is Operation.THROW else op.title
    on = f" on {where}" if where else ""
    return f"{name} running{on}: {s.progress[0] or op.doing}"


def machine_words(world_title: str, arm_description: str) -> str:
    """The world and the arm in a few words, for the status line: "MuJoCo (simulated) Mitsubishi
    PA-10" (the arm spec's description up to its first parenthesis)."""
    arm = arm_description.split(" (")[0].strip()
    return " ".join(part for part in (world_title, arm) if part)


def status_text(s: SessionSnapshot, *, calibrated: bool, arm_connected: bool = True, where: str = "") -> str:
    """Markdown: what runs and on what (`running_line`, or Idle), the calibration's one state, the
    alignment, the preview, and the session's message below."""
    calibrating = s.operation in (Operation.CALIBRATE, Operation.CALIBRATE_WAND)
    if s.busy:
        if calibrating:
            on = f" on {where}" if where else ""
            head = f"**{s.operation.title if s.operation is not None else 'Calibration'} running{on}**: "
            head += calibration_state(s, calibrated)
        else:
            head = f"**{running_line(s, where)}**"
    else:
        head = "**Idle**"
    # one calibration state: while a calibration runs the head says its progress, and nothing else does
    facts = [] if calibrating else [calibration_state(s, calibrated)]
    if not arm_connected:
        facts.append("arm parked at its home pose (no driver): tracking only")
    if s.alignment is not None:
        facts.append("target aligned" if s.alignment.converged else f"target not aligned: {s.alignment.message}")
    if s.preview is not None:
        facts.append(f"preview {s.preview.id} ready")
    text = head + (" · " + ", ".join(facts) if facts else "")
    if s.message:
        text += f"\n\n{s.message}"
    return text


class Panels:
    """The GUI of one dashboard (see the module docstring)."""

    def __init__(
        self,
        server: viser.ViserServer,
        camera_names: Sequence[str],
        on_stop: Callable[[viser.GuiEvent], None],
        world_title: str = "",
        still_progress: bool = False,
        where: str = "",
    ) -> None:
        gui = server.gui
        self.where = where  # the world and the arm, as the status line names them (`machine_words`)
        gui.configure_theme(control_width="large")
        self.stop = gui.add_button(
            "Stop",
            color="red",
            icon=viser.Icon.HAND_STOP,
            hint="brake the arm to rest now (always allowed, for everyone)",
        )
        self.stop.on_click(on_stop)
        self.status = gui.add_markdown("**Starting**")
        # which world the buttons act on (the commands' first line says the same)
        self.world_md = gui.add_markdown(f"World: {world_title}", visible=bool(world_title))
        # `still_progress`: without the moving stripes, a CSS animation that a browser rendering in
        # software redraws at its full frame rate for as long as an operation runs (`--plain-scene`)
        self.progress = gui.add_progress_bar(0.0, animated=not still_progress, visible=False)

        with gui.add_folder("Cameras"):
            self.cameras = CameraViews(gui, camera_names)

        # each browser's controls go between these (wiithrow.web.controls.ORDER)
        with gui.add_folder("Calibration") as self.calibration_folder:
            self.calibration_md = gui.add_markdown("", order=3.0)
            self.loo_plot = gui.add_uplot(
                (np.array([7.0, 30.0]), np.array([np.nan, np.nan]), np.array([np.nan, np.nan])),
                (
                    {"label": "points"},
                    {"label": "refined (mm)", "stroke": "#4363d8", "width": 2, "points": {"show": True, "size": 6}},
                    {"label": "paper (mm)", "stroke": "#e6194b", "width": 1.5, "dash": (4.0, 4.0)},
                ),
                title="leave-one-out error vs points",
                scales=NO_X_TIME,
                aspect=1.6,
                visible=False,
                axes=({"label": "calibration points"}, {"label": "mm"}),
                order=4.0,
            )

        with gui.add_folder("Throw") as self.throw_folder:
            self.throw_md = gui.add_markdown("No preview.", order=5.0)
            self.hand_md = gui.add_markdown("", order=5.5, visible=False)
            n = len(JOINT_COLORS)
            series: list[uplot.Series] = [{"label": "t (s)"}]
            series += [{"label": f"q{j + 1}", "stroke": JOINT_COLORS[j], "width": 1.5} for j in range(n)]
            series.append({"label": "limit", "stroke": "#000000", "width": 1, "dash": (6.0, 4.0)})
            self.speed_plot = gui.add_uplot(
                (np.array([0.0, 1.0]),) + tuple(np.array([np.nan, np.nan]) for _ in range(n + 1)),
                tuple(series),
                title="joint speed / limit",
                scales={"x": {"time": False}, "y": {"range": (0.0, 1.1)}},
                aspect=1.6,
                visible=False,
                axes=({"label": "s"}, {"label": "|dq| / limit"}),
                order=6.0,
            )

        with gui.add_folder("Last throws"):
            self.table = gui.add_markdown("No throws yet.")

        with gui.add_folder("Mono vs stereo", expand_by_default=False):
            self.mono_md = gui.add_markdown("Computed after the calibration (Fig. 6 of the paper).")
            self.mono_plot = gui.add_uplot(
                (np.array([0.0, 75.0]), np.array([np.nan, np.nan]), np.array([np.nan, np.nan])),
                (
                    {"label": "angle (deg)"},
                    {"label": "mono (mm)", "stroke": "#e6194b", "width": 2, "points": {"show": True, "size": 6}},
                    {"label": "stereo (mm)", "stroke": "#4363d8", "width": 2, "points": {"show": True, "size": 6}},
                ),
                title="depth error vs beacon angle",
                scales=NO_X_TIME,
                aspect=1.6,
                visible=False,
                axes=({"label": "beacon line to image plane (deg)"}, {"label": "|depth error| mm"}),
            )
        self._texts: dict[str, str] = {}

    # -- updates ------------------------------------------------------------------------------------------

    def _set_md(self, name: str, handle, text: str) -> None:
        if self._texts.get(name) != text:
            self._texts[name] = text
            handle.content = text

    def show_hand(self, opening: float | None, holding: bool | None) -> None:
        """The gripper's jaws (0 closed, 1 open) and whether it holds the ball; hidden without one."""
        if opening is None:
            return
        held = {True: ", holding the ball", False: ", empty", None: ""}[holding]
        text = f"Hand: jaws {100 * opening:.0f} % open{held}"
        if self.hand_md.content != text:
            self.hand_md.content = text
        if not self.hand_md.visible:
            self.hand_md.visible = True

    def update_session(
        self,
        s: SessionSnapshot,
        *,
        calibrated: bool,
        worst: Sequence[tuple[int, float]] = (),
        arm_connected: bool = True,
    ) -> None:
        """Show a new snapshot: status, progress, calibration, preview, throws."""
        self._set_md(
            "status", self.status, status_text(s, calibrated=calibrated, arm_connected=arm_connected, where=self.where)
        )
        if s.busy:
            value = float(np.clip(100.0 * s.progress[1], 0.0, 100.0))
            if self.progress.value != value:
                self.progress.value = value  # type: ignore[misc]  # settable at run time; viser 1.1's type says read-only
            if not self.progress.visible:
                self.progress.visible = True
        elif self.progress.visible:
            self.progress.visible = False
        self._set_md("calibration", self.calibration_md, calibration_summary(s, worst, calibrated=calibrated))
        self._set_md("table", self.table, throws_table(s))
        self._set_md("throw", self.throw_md, preview_text(s))

    def show_preview_speeds(self, times: NDArray[np.float64] | None, ratios: NDArray[np.float64] | None) -> None:
        """|dq_j(t)| / limit_j of the previewed motion (K,), (K, nq); None hides the plot."""
        if times is None or ratios is None:
            self.speed_plot.visible = False
            return
        n = len(JOINT_COLORS)
        series = [ratios[:, j] if j < ratios.shape[1] else np.full(len(times), np.nan) for j in range(n)]
        self.speed_plot.data = (np.asarray(times, float), *series, np.ones(len(times)))
        self.speed_plot.visible = True

    def show_loo_curve(
        self, sizes: NDArray[np.float64], refined_mm: NDArray[np.float64], paper_mm: NDArray[np.float64]
    ) -> None:
        self.loo_plot.data = (np.asarray(sizes, float), np.asarray(refined_mm, float), np.asarray(paper_mm, float))
        self.loo_plot.visible = True

    def show_mono_vs_stereo(
        self, angles: NDArray[np.float64], mono_mm: NDArray[np.float64], stereo_mm: NDArray[np.float64], note: str
    ) -> None:
        self.mono_plot.data = (np.asarray(angles, float), np.asarray(mono_mm, float), np.asarray(stereo_mm, float))
        self.mono_plot.visible = True
        self._set_md("mono", self.mono_md, note)


def preview_text(s: SessionSnapshot) -> str:
    """Markdown: the alignment and the current preview."""
    lines = []
    a = s.alignment
    if a is not None:
        lines.append(
            f"Target in the throw plane: x {a.throw_xz[0]:.3f} m, z {a.throw_xz[1]:.3f} m "
            f"(joint 1 {np.degrees(a.q1):.1f}°, {a.status})"
        )
    p = s.preview
    if p is not None:
        worst = int(np.argmax(p.speed_ratio))
        lines.append(
            f"**Preview {p.id}**: predicted landing x {p.predicted_xz[0]:.3f} m, z {p.predicted_xz[1]:.3f} m; "
            f"{p.duration_s:.2f} s; fastest joint q{worst + 1} at {100 * p.speed_ratio[worst]:.0f} % of its limit"
        )
    elif s.history and not s.busy:
        r = s.history[-1]
        lines.append(f"Last throw #{r.index}: {throw_outcome(r)}")
    return "\n\n".join(lines) if lines else "No preview."
