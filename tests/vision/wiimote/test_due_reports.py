"""A simulated remote read all at once and not read before a report is due (`link.DueReports`)
gives the driver exactly what reading it report by report, every poll, gives: the same bytes at
the same times, the same frames, the same counts, through faults and reconnects."""

from __future__ import annotations

import numpy as np
import pytest

from wiithrow.clock import SimClock
from wiithrow.vision.camera import WiimoteCamera
from wiithrow.vision.wiimote.device import WiimoteDriver
from wiithrow.vision.wiimote.driver_settings import DriverSettings
from wiithrow.vision.wiimote.link import DueReports
from wiithrow.vision.wiimote.sim_faults import SimFaults
from wiithrow.vision.wiimote.simulator import SimulatedWiimote

CAM = WiimoteCamera.at([0.0, 0.0, 0.0], [1.0, 0.0, 0.0], name="cam0")


def sources(t: float) -> np.ndarray:
    return np.array([[1.2, 0.3 - 0.1 * t, 0.05], [1.6, -0.25 + 0.05 * t, 0.1 * np.sin(3 * t)], [2.0, 0.0, 0.1]])


class ReportByReport:
    """The simulated remote behind nothing but the `Transport` methods (as a real device)."""

    def __init__(self, sim: SimulatedWiimote) -> None:
        self.sim = sim

    def open(self) -> None:
        self.sim.open()

    def close(self) -> None:
        self.sim.close()

    def write(self, data: bytes) -> int:
        return self.sim.write(data)

    def read(self, max_size: int, timeout_ms: int) -> bytes:
        return self.sim.read(max_size, timeout_ms)


FAULTS = {
    "none": SimFaults(),
    "drops and garbage": SimFaults(drop_probability=0.1, garbage_probability=0.05, zero_first=True),
    "stall": SimFaults(stall_at=1.3),
    "disconnect": SimFaults(disconnect_at=0.9, reconnect_after=0.4),
}


def run(faults: SimFaults, *, direct: bool, ir_format: str, step_s: float, statuses: tuple[float, ...] = (1.7,)):
    clock = SimClock()
    sim = SimulatedWiimote(CAM, sources, clock, np.random.default_rng(4), faults=faults, phase_s=0.0037)
    reads = [0]  # the remote's read() calls: what the fast path saves
    read = sim.read

    def counted_read(max_size: int, timeout_ms: int = 0) -> bytes:
        reads[0] += 1
        return read(max_size, timeout_ms)

    sim.read = counted_read  # type: ignore[method-assign]
    transport = sim if direct else ReportByReport(sim)
    assert isinstance(transport, DueReports) is direct
    drv = WiimoteDriver(transport, clock, DriverSettings(ir_format=ir_format))
    seen: list[tuple[float, bytes]] = []
    drv.subscribe_reports(seen.extend)
    frames = []
    pending = list(statuses)
    for _ in range(round(3.0 / step_s)):
        clock.advance(step_s)
        if pending and clock.now() >= pending[0]:
            pending.pop(0)
            sim.send_unsolicited_status()
        frames += drv.poll()
    nan = -1.0  # NaN != NaN: compare empty slots as -1
    frame_data = [
        (
            f.t,
            f.t_device,
            f.seq,
            f.report_id,
            np.nan_to_num(f.dots, nan=nan).tolist(),
            np.nan_to_num(f.sizes, nan=nan).tolist(),
        )
        for f in frames
    ]
    return seen, frame_data, drv.stats, sim.stats, drv.state, reads[0]


@pytest.mark.parametrize("fault", sorted(FAULTS))
@pytest.mark.parametrize(("ir_format", "step_s"), [("extended", 0.001), ("full", 0.001), ("extended", 0.01)])
def test_all_at_once_and_only_when_due_equals_report_by_report(fault, ir_format, step_s):
    fast = run(FAULTS[fault], direct=True, ir_format=ir_format, step_s=step_s)
    plain = run(FAULTS[fault], direct=False, ir_format=ir_format, step_s=step_s)
    seen, frames, drv_stats, sim_stats, state, reads = fast
    assert len(frames) > 50  # it streamed (50 Hz full frames, 100 Hz extended, for most of 3 s)
    assert seen == plain[0]
    assert frames == plain[1]
    assert (drv_stats, sim_stats, state) == plain[2:5]
    assert reads < plain[5] / 2  # the stream's reads went through read_all, the idle polls read nothing
    if fault != "none":
        assert drv_stats.camera_restarts + drv_stats.disconnects + drv_stats.bad_reports + sim_stats.dropped > 0
