"""Reports become frames, with no transport: `ReportDecoder`, the pure half of the driver.

`ReportDecoder.decode(batch)` takes input reports read back to back, as (arrival time, bytes),
and returns the `IRFrame`s they make: every report is parsed (`input_reports.parse`; a
`ProtocolError` is counted in `stats.bad_reports` and skipped), the IR reports' send times are
estimated from the batch (`frames.device_times`) and assembled into frames (`frames.FrameAssembler`:
the full format's two halves paired, frames numbered, losses counted). Status reports update
`battery` and set `status_seen`, which the driver answers by sending its reporting mode again;
replaying recorded reports simply ignores it.

`reports` is the list of listeners of the raw reports, shown every batch before it is decoded
(`subscribe`: what a recording keeps). The live driver (`device.WiimoteDriver`) and a replay
(`wiithrow.app.recording.replay`) decode with this one class, so a replay gives the live frames.
"""

from __future__ import annotations

import logging
from collections.abc import Callable

from wiithrow.listeners import Listeners, Unsubscribe
from wiithrow.vision.wiimote.driver_settings import DriverStats
from wiithrow.vision.wiimote.frames import FrameAssembler, IRFrame, device_times
from wiithrow.vision.wiimote.input_reports import IRReport, Report, StatusReport, parse
from wiithrow.vision.wiimote.protocol import ProtocolError

#: A batch of input reports as read: (arrival time on the clock, the report's bytes).
Batch = list[tuple[float, bytes]]


class ReportDecoder:
    """One remote's input reports -> `IRFrame`s (see the module docstring)."""

    def __init__(
        self, stats: DriverStats | None = None, *, name: str = "wiimote", logger: logging.Logger | None = None
    ) -> None:
        self.stats = stats if stats is not None else DriverStats()
        self.name = name
        self.log = logger or logging.getLogger(f"wiithrow.vision.wiimote.{name}")
        self.assembler = FrameAssembler(self.stats)
        self.reports: Listeners[Batch] = Listeners(f"{name}'s reports", on_failure=self._listener_failed)
        self.battery: int | None = None
        self.last_ir_t = 0.0  # arrival time of the last IR report
        self.status_seen = False  # a status report was decoded (the driver clears it when it answers)

    def subscribe(self, listener: Callable[[Batch], object]) -> Unsubscribe:
        """Show every batch of raw reports to `listener` before it is decoded."""
        return self.reports.subscribe(listener)

    def show(self, batch: Batch) -> None:
        """Tell the listeners of raw reports (a report read alone, while waiting for an ack, too)."""
        if self.reports and batch:
            self.reports.emit(batch)

    def decode(self, batch: Batch) -> list[IRFrame]:
        """The frames that a batch read back to back makes, oldest first.

        A batch of one report (a poll every few milliseconds finds one) is sent when it arrived
        (`device_times` of one report: min(t_arr, t_end) = t_arr), so it skips the batch's
        bookkeeping (`decode_batch`, the same frames and counts: test_decoder)."""
        if len(batch) != 1:
            return self.decode_batch(batch)
        self.show(batch)
        t_arr, data = batch[0]
        rep = self.parse(data)
        if rep is None:
            return []
        frame = self.dispatch(rep, t_arr, t_arr)
        return [] if frame is None else [frame]

    def decode_batch(self, batch: Batch) -> list[IRFrame]:
        """`decode` for any batch: parse all, estimate the IR reports' send times, dispatch."""
        self.show(batch)
        parsed: list[tuple[float, Report]] = []
        for t_arr, data in batch:
            rep = self.parse(data)
            if rep is not None:
                parsed.append((t_arr, rep))
        if not parsed:
            return []
        t_end = batch[-1][0]
        frames: list[IRFrame] = []
        for (t_arr, rep), t_dev in zip(parsed, device_times(parsed, t_end)):
            frame = self.dispatch(rep, t_arr, t_dev)
            if frame is not None:
                frames.append(frame)
        return frames

    def parse(self, data: bytes) -> Report | None:
        """The report in `data`, or None (counted and logged) when it is not a valid one."""
        try:
            return parse(data)
        except ProtocolError as exc:
            self.stats.bad_reports += 1
            self.log.debug("%s: skipped a bad report: %s", self.name, exc)
            return None

    def dispatch(self, rep: Report, t_arr: float, t_dev: float) -> IRFrame | None:
        """Count one parsed report; the frame it completes, if any."""
        self.stats.reports += 1
        if isinstance(rep, IRReport):
            self.last_ir_t = t_arr
            return self.assembler.add(rep, t_arr, t_dev)
        if isinstance(rep, StatusReport):
            self.stats.status_reports += 1
            self.battery = rep.battery
            self.status_seen = True
            return None
        self.stats.unexpected_reports += 1
        return None

    def _listener_failed(self) -> None:
        self.stats.callback_errors += 1
