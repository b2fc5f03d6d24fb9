"""The decoder's one-report fast path gives what its batch path gives, frame for frame."""

from __future__ import annotations

import numpy as np
import pytest

from wiithrow.clock import SimClock
from wiithrow.vision.camera import WiimoteCamera
from wiithrow.vision.wiimote.decoder import ReportDecoder
from wiithrow.vision.wiimote.device import WiimoteDriver
from wiithrow.vision.wiimote.driver_settings import DriverSettings
from wiithrow.vision.wiimote.sim_faults import SimFaults
from wiithrow.vision.wiimote.simulator import SimulatedWiimote

CAM = WiimoteCamera.at([0.0, 0.0, 0.0], [1.0, 0.0, 0.0], name="cam0")


def sources(t: float) -> np.ndarray:
    return np.array([[1.2, 0.3 - 0.1 * t, 0.05], [1.6, -0.25 + 0.05 * t, 0.1 * np.sin(3 * t)], [2.0, 0.0, 0.1]])


def recorded(ir_format: str) -> list[tuple[float, bytes]]:
    """Every report a driver read in 2 s of 1 ms polls, with garbage, drops and status reports."""
    clock = SimClock()
    faults = SimFaults(drop_probability=0.05, garbage_probability=0.05, zero_first=True)
    sim = SimulatedWiimote(CAM, sources, clock, np.random.default_rng(8), faults=faults)
    drv = WiimoteDriver(sim, clock, DriverSettings(ir_format=ir_format))
    reports: list[tuple[float, bytes]] = []
    drv.subscribe_reports(reports.extend)
    for k in range(2000):
        clock.advance(0.001)
        if k % 500 == 250:
            sim.send_unsolicited_status()
        drv.poll()
    return reports


def decoded(decode, reports):
    out = []
    for report in reports:
        for f in decode([report]):
            out.append((f.t, f.t_device, f.seq, f.report_id, np.nan_to_num(f.dots, nan=-1.0).tolist()))
            out.append((np.nan_to_num(f.sizes, nan=-1.0).tolist(), np.nan_to_num(f.bboxes, nan=-1.0).tolist()))
    return out


@pytest.mark.parametrize("ir_format", ["basic", "extended", "full"])
def test_one_report_fast_path_equals_the_batch_path(ir_format):
    reports = recorded(ir_format)
    fast, plain = ReportDecoder(), ReportDecoder()
    a, b = decoded(fast.decode, reports), decoded(plain.decode_batch, reports)
    assert len(a) > 100
    assert a == b
    assert fast.stats == plain.stats
    assert fast.stats.bad_reports > 0 and fast.stats.status_reports > 0
    assert (fast.battery, fast.last_ir_t, fast.status_seen) == (plain.battery, plain.last_ir_t, plain.status_seen)
