"""The Wand panel: a wand calibration started from the dashboard, its coverage and its result.

Owns `coverage_image` (pure numpy: a camera's 1024 x 768 image as the 8 x 6 grid of
`wiithrow.vision.wand.quality`, each cell shaded by how many wand dots fell in it, dark where none
did), `wand_summary` (the result as markdown: per camera RMS, focal length and coverage, the wand
score, the held-out error, the frame, warnings), `WandPanel` (the shared part of the Wand folder:
one coverage image per camera, the summary) and `WandInputs` (each browser's own wand length,
seconds, frame and Start, built with its controls: a guest's are disabled; an operator's Start
follows the session's refusal of a wand calibration, `wiithrow.web.controls`). It only shows and
asks: Start calls back, and the server decides whether the clicking browser may start anything
(operators only, when the session allows it); Stop is the dashboard's Stop.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence

import numpy as np
import viser
from numpy.typing import NDArray

from wiithrow.app.calibration.wand import FRAMES, WandRun
from wiithrow.app.calibration.wand_capture import CaptureProgress
from wiithrow.vision.wand.quality import MIN_DOTS_PER_CELL

_EMPTY = np.array((24, 26, 32), dtype=np.uint8)
_VISITED_LOW = np.array((40, 90, 60), dtype=np.float64)
_VISITED_HIGH = np.array((90, 230, 120), dtype=np.float64)
_FEW = np.array((110, 90, 40), dtype=np.uint8)  # a dot or two: not yet counted as visited
_GRID = np.array((52, 56, 66), dtype=np.uint8)


def coverage_image(counts: NDArray[np.int64], *, width: int = 256, height: int = 192) -> NDArray[np.uint8]:
    """A (height, width, 3) picture of one camera's coverage map (rows, cols): dark where the wand
    never was, amber below `MIN_DOTS_PER_CELL` dots, green brighter with the log of the count."""
    rows, cols = counts.shape
    colours = np.empty((rows, cols, 3), dtype=np.uint8)
    colours[:] = _EMPTY
    colours[(counts > 0) & (counts < MIN_DOTS_PER_CELL)] = _FEW
    visited = counts >= MIN_DOTS_PER_CELL
    if visited.any():
        level = np.log1p(counts[visited]) / np.log1p(max(int(counts.max()), MIN_DOTS_PER_CELL))
        colours[visited] = (_VISITED_LOW + level[:, None] * (_VISITED_HIGH - _VISITED_LOW)).astype(np.uint8)
    r = np.minimum(np.arange(height) * rows // height, rows - 1)
    c = np.minimum(np.arange(width) * cols // width, cols - 1)
    image: NDArray[np.uint8] = colours[r[:, None], c[None, :]]
    image[np.diff(r, prepend=-1) != 0, :] = _GRID
    image[:, np.diff(c, prepend=-1) != 0] = _GRID
    return image


def wand_summary(run: WandRun | None, progress: CaptureProgress | None, capturing: bool) -> str:
    """The panel's text: the capture under way, or the last result, or how to start."""
    if capturing:
        if progress is None:
            return "**Recording**: wave the wand through the volume, turning it."
        both = ", ".join(str(int(n)) for n in progress.both)
        return f"**Recording** {100 * progress.done:.0f} %: {progress.frames} frames, both LEDs seen in {both}"
    if run is None:
        return "No wand calibration: set the wand's length and press **Start**, then wave the wand for the time set."
    q = run.result.quality
    lines = [
        f"**Wand calibration** in frame **{run.calibration.frame}**: wand score **{q.wand_score_percent:.2f} %**, "
        f"held-out error {1e3 * q.heldout_length_rms_m:.2f} mm",
        " · ".join(
            f"{name} {rms:.2f} px, {100 * f:.0f} % covered"
            for name, rms, f in zip(q.names, q.reprojection_rms_px, q.coverage_fraction)
        ),
    ]
    if run.frame_fit is not None:
        lines.append(f"frame fitted to {len(run.frame_fit.residuals_m)} points, {1e3 * run.frame_fit.rms_m:.2f} mm RMS")
    lines += [f"⚠ {w}" for w in q.warnings]
    return "\n\n".join(lines)


#: Place of the Wand folder's elements: each browser's own inputs (`WandInputs`) first, then the
#: shared coverage images and summary.
INPUT_ORDER = {"length": 1.0, "seconds": 2.0, "frame": 3.0, "start": 4.0}
SHARED_ORDER = 10.0
START_HINT = "record the wand for the time set, then fit"


class WandInputs:
    """One browser's wand inputs and Start (`gui`: that client's GUI API, inside the Wand folder).
    A guest's are disabled and say why; an operator's Start calls
    `on_start(event, wand_length_m, seconds, frame)`."""

    def __init__(
        self,
        gui: viser.GuiApi,
        on_start: Callable[[viser.GuiEvent, float, float, str], None] | None,
        *,
        frames: Sequence[str] = FRAMES,
        disabled_reason: str = "",
    ) -> None:
        off = bool(disabled_reason)

        def hint(text: str) -> str:
            return f"{text} ({disabled_reason})" if off else text

        o = INPUT_ORDER
        self.length = gui.add_number(
            "Wand length (m)", 0.3, min=0.02, max=3.0, step=0.001, order=o["length"], disabled=off,
            hint=hint("distance between the wand's LED centres"),
        )  # fmt: skip
        self.seconds = gui.add_number(
            "Seconds", 60.0, min=5.0, max=600.0, step=5.0, order=o["seconds"], disabled=off,
            hint=hint("how long to record the waving"),
        )  # fmt: skip
        self.frame = gui.add_dropdown(
            "Frame", tuple(frames), initial_value=frames[0], order=o["frame"], disabled=off,
            hint=hint("the calibration's frame: the first camera's, or the robot's (link1, from arm poses)"),
        )  # fmt: skip
        self.start_hint = START_HINT
        self.start = gui.add_button(
            "Start wand calibration", icon=viser.Icon.WAND, hint=hint(START_HINT), order=o["start"], disabled=off
        )
        if on_start is not None and not off:
            self.start.on_click(
                lambda event: on_start(
                    event, float(self.length.value), float(self.seconds.value), str(self.frame.value)
                )
            )


class WandPanel:
    """The Wand folder's shared elements: one coverage image per camera and the summary (`gui`:
    viser's GUI API, inside the folder). Each browser's inputs are its `WandInputs`."""

    def __init__(self, gui: viser.GuiApi, names: Sequence[str], *, width: int = 256, height: int = 192) -> None:
        self.width, self.height = width, height
        blank = coverage_image(np.zeros((6, 8), dtype=np.int64), width=width, height=height)
        self.coverage = [
            gui.add_image(blank, label=f"{name}: coverage", format="png", order=SHARED_ORDER + i)
            for i, name in enumerate(names)
        ]
        self.summary = gui.add_markdown(wand_summary(None, None, False), order=SHARED_ORDER + len(names))
        self._drawn: list[object] = [None] * len(self.coverage)
        self._text = ""

    def show(self, run: WandRun | None, progress: CaptureProgress | None, capturing: bool) -> int:
        """Draw the capture's coverage (or the result's) and the summary; returns the images re-sent."""
        maps = progress.coverage if capturing and progress is not None else None
        if maps is None and run is not None:
            maps = run.result.quality.coverage
        sent = 0
        if maps is not None:
            for c, image in enumerate(self.coverage[: len(maps)]):
                key = maps[c].tobytes()
                if key != self._drawn[c]:
                    self._drawn[c] = key
                    image.image = coverage_image(maps[c], width=self.width, height=self.height)
                    sent += 1
        text = wand_summary(run, progress, capturing)
        if text != self._text:
            self._text = text
            self.summary.content = text
        return sent
