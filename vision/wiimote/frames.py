"""IR reports become camera frames: `IRFrame`, and the `FrameAssembler` that makes them.

The assembler owns everything between a parsed IR report and a frame: the full format's two
halves (0x3E carries dot slots 0-1, the 0x3F that follows it slots 2-3) are paired into one frame,
frames are numbered over the driver's life (across reconnects), and the reports' send times and
losses are estimated. No I/O: the driver (`device`) reads and parses, the assembler assembles.

Time stamps: `IRFrame.t` is the arrival time on the clock. The remote sends no time stamp or
counter, so `t_device` estimates when the remote sent the report (`device_times`): reports read
together in one batch were queued at 10 ms intervals and the newest one arrived just now. Lost
reports are counted from the same estimate (`DriverStats.drops_detected`): exact when reports are
read at least every 10 ms, within one report otherwise. A stream that stops (camera restart,
disconnect) closes a segment of the count (`end_segment`).

Send times never go back (`FrameAssembler.add`): a batch read late can hold more reports than the
time since the previous read spans (a loaded reader, a link that bunched them), and spaced back
from the newest its first would be sent before the previous batch's last, which the remote sent
earlier; the synchroniser then refused it ("older than the previous one"). Each report is sent
at least 10 ms after the one before it, and never after it arrived, so

    t_dev = min(t_arr, max(estimate, t_dev_previous + 10 ms)),  then at least t_dev_previous + 1 us

(the microsecond keeps the times strictly increasing when reports arrive together). A report
that arrives before the previous one did starts a new timeline (recorded reports decoded again
from their start, a clock set back): nothing is carried over it.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from wiithrow.vision.wiimote.driver_settings import DriverStats
from wiithrow.vision.wiimote.input_reports import IRReport, Report, combine_interleaved_accel
from wiithrow.vision.wiimote.ir_dots import BBox, Dot
from wiithrow.vision.wiimote.protocol import IN_INTERLEAVED_A, IN_INTERLEAVED_B, Button, IRFormat

#: The remote sends a data report every 10 ms.
REPORT_PERIOD_S = 0.01
#: The least step between two send-time estimates (s): they strictly increase.
MIN_STEP_S = 1e-6
_NAN_DOTS = np.full((4, 2), np.nan)
_NAN_4 = np.full(4, np.nan)
_NAN_BOXES = np.full((4, 4), np.nan)
#: A frozen dataclass's instance with no fields yet: `FrameAssembler._frame` sets them in one
#: dictionary update, where `IRFrame.__init__` calls `object.__setattr__` once per field (2 us
#: of a remote's 100 frames a second; `test_frames` compares the two).
_new = object.__new__


@dataclass(frozen=True, eq=False)
class IRFrame:
    """One camera frame as the driver decoded it.

    `dots` (4, 2) float pixels, NaN for an empty slot; `sizes` (4,) blob sizes (NaN where absent
    or in the basic format); `intensities` (4,) and `bboxes` (4, 4) (xmin, ymin, xmax, ymax on
    the 128x96 sensor) in the full format, NaN otherwise. `t` is the arrival time on the clock,
    `t_device` the estimated send time (see the module docstring), `seq` counts frames from 0 over
    the driver's life (across reconnects), `report_id` is the report that completed the frame.
    """

    t: float
    t_device: float
    seq: int
    report_id: int
    dots: NDArray[np.float64]
    sizes: NDArray[np.float64]
    buttons: Button
    accel: tuple[int, int, int] | None = None
    intensities: NDArray[np.float64] = field(default_factory=lambda: np.full(4, np.nan))
    bboxes: NDArray[np.float64] = field(default_factory=lambda: np.full((4, 4), np.nan))

    @property
    def visible(self) -> NDArray[np.bool_]:
        """Which of the four slots hold a dot."""
        visible: NDArray[np.bool_] = np.all(np.isfinite(self.dots), axis=1)
        return visible


def device_times(parsed: Sequence[tuple[float, Report]], t_end: float) -> list[float]:
    """Estimated send times of reports read back to back, given as (arrival time, report).

    The IR reports were queued at 10 ms intervals and the last one left the remote at `t_end` at
    the latest: the k-th IR report from the end was sent at min(arrival, t_end - k * 10 ms).
    Other reports keep their arrival time.
    """
    n_ir_after = sum(isinstance(rep, IRReport) for _, rep in parsed)
    times = []
    for t_arr, rep in parsed:
        if isinstance(rep, IRReport):
            n_ir_after -= 1
            times.append(min(t_arr, t_end - n_ir_after * REPORT_PERIOD_S))
        else:
            times.append(t_arr)
    return times


class FrameAssembler:
    """Turns a driver's IR reports into `IRFrame`s, counting in the driver's `stats`
    (ir_reports, frames, drops_detected, incomplete_pairs); see the module docstring."""

    def __init__(self, stats: DriverStats) -> None:
        self.stats = stats
        self._seq = 0
        self._half: tuple[IRReport, float, float] | None = None  # pending 0x3E, its t_arr and t_dev
        self._seg_t0: float | None = None  # drop estimate: device time of the segment's first report
        self._seg_n = 0
        self._seg_drops = 0
        self._drops_closed = 0
        self._last_t_dev = -np.inf
        self._last_t_arr = -np.inf

    def add(self, rep: IRReport, t_arr: float, t_dev: float) -> IRFrame | None:
        """One IR report (arrived at `t_arr`, sent at about `t_dev`); the frame it completes, if any.
        `t_dev` is kept after the previous report's (module docstring)."""
        if t_arr < self._last_t_arr:
            self._last_t_dev = -np.inf  # a new timeline
        elif t_dev < self._last_t_dev + REPORT_PERIOD_S:
            t_dev = max(min(t_arr, self._last_t_dev + REPORT_PERIOD_S), self._last_t_dev + MIN_STEP_S)
        self._last_t_dev, self._last_t_arr = t_dev, t_arr
        self._count(t_dev)
        if rep.report_id == IN_INTERLEAVED_A:
            if self._half is not None:
                self.stats.incomplete_pairs += 1
            self._half = (rep, t_arr, t_dev)
            return None
        if rep.report_id == IN_INTERLEAVED_B:
            half, self._half = self._half, None
            if half is None or t_dev - half[2] > 1.5 * REPORT_PERIOD_S:
                self.stats.incomplete_pairs += 1
                return None
            first = half[0]
            dots = {**first.dots, **rep.dots}
            sizes = {**first.sizes, **rep.sizes}
            bboxes = {**first.bboxes, **rep.bboxes}
            intens = {**first.intensities, **rep.intensities}
            accel = combine_interleaved_accel(first, rep)
            return self._frame(t_arr, half[2], rep.report_id, dots, sizes, rep.buttons, accel, bboxes, intens)
        sizes = rep.sizes if rep.ir_format is IRFormat.EXTENDED else {}
        return self._frame(t_arr, t_dev, rep.report_id, rep.dots, sizes, rep.buttons, rep.accel, {}, {})

    def forget_half(self) -> None:
        """Drop a pending 0x3E half (the stream is being set up again)."""
        self._half = None

    def end_segment(self) -> None:
        """The stream stopped (camera restart, disconnect): close the drop count's segment (the
        next report starts a new one) and forget a pending half."""
        self._drops_closed += self._seg_drops
        self._seg_t0, self._seg_n, self._seg_drops = None, 0, 0
        self.stats.drops_detected = self._drops_closed
        self._half = None

    def _count(self, t_dev: float) -> None:
        """Count an IR report and the reports lost before it in this segment: those the 10 ms
        period says were sent since the segment's first report, minus those that arrived."""
        self.stats.ir_reports += 1
        if self._seg_t0 is None:
            self._seg_t0, self._seg_n = t_dev, 0
        self._seg_n += 1
        est = round((t_dev - self._seg_t0) / REPORT_PERIOD_S) + 1 - self._seg_n
        self._seg_drops = max(0, est)
        self.stats.drops_detected = self._drops_closed + self._seg_drops

    def _frame(
        self,
        t: float,
        t_dev: float,
        report_id: int,
        dots: dict[int, Dot],
        sizes: dict[int, int],
        buttons: Button,
        accel: tuple[int, int, int] | None,
        bboxes: dict[int, BBox],
        intensities: dict[int, int],
    ) -> IRFrame:
        d = _NAN_DOTS.copy()  # copying a template costs a fraction of np.full (100 Hz per remote)
        s = _NAN_4.copy()
        inten = _NAN_4.copy()
        bb = _NAN_BOXES.copy()
        for slot, (x, y) in dots.items():
            d[slot, 0] = x  # (two scalar writes: `d[slot] = (x, y)` makes an array of the pair first)
            d[slot, 1] = y
            if slot in sizes:
                s[slot] = sizes[slot]
            if slot in intensities:
                inten[slot] = intensities[slot]
            if slot in bboxes:
                bb[slot] = bboxes[slot]
        frame = _new(IRFrame)  # `IRFrame(t, t_dev, ...)`, its fields set at once (`_new`)
        frame.__dict__.update(
            t=t,
            t_device=t_dev,
            seq=self._seq,
            report_id=report_id,
            dots=d,
            sizes=s,
            buttons=buttons,
            accel=accel,
            intensities=inten,
            bboxes=bb,
        )
        self._seq += 1
        self.stats.frames += 1
        return frame
