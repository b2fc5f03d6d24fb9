"""Simulated remotes for the simulated system: one `SimulatedWiimote` per camera of a rig, each
behind the real driver, looking at IR sources given as a function of time.

Each remote keeps the truth of its last `TRUTH_REPORTS` reports (`SimulatedWiimote.history`), not
the simulator's default of 100 000 (17 minutes at 100 Hz, about 60 MB of Python objects for two
remotes, most of the 140 MB a demo's resident memory grew by in its first half hour): nothing
in the running system reads it, and a demo or a soak runs for hours.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from wiithrow.clock import Clock
from wiithrow.vision.camera import WiimoteCamera
from wiithrow.vision.wiimote.device import WiimoteDriver
from wiithrow.vision.wiimote.driver_settings import DriverSettings
from wiithrow.vision.wiimote.sim_faults import SimFaults
from wiithrow.vision.wiimote.sim_reports import Sources
from wiithrow.vision.wiimote.simulator import SimulatedWiimote

#: Reports whose truth each simulated remote keeps (10 s at 100 Hz).
TRUTH_REPORTS = 1_000


def simulated_drivers(
    cameras: Sequence[WiimoteCamera],
    sources: Sources,
    clock: Clock,
    rng: np.random.Generator,
    *,
    sigma_px: float = 0.5,
    realtime: bool = False,
    ir_format: str = "extended",
    sensitivity: str = "level3",
    faults: Sequence[SimFaults | None] | None = None,
) -> tuple[list[WiimoteDriver], list[SimulatedWiimote]]:
    """A driver per camera over a simulated remote (player LED c + 1 for camera c).

    `sources(t)` gives the IR sources (M, 3) in the cameras' mount frame at time t. Each remote
    draws its noise from its own generator spawned from `rng`, and its report clock starts at a
    random phase within the 10 ms period (real remotes are not synchronised).
    """
    drivers, remotes = [], []
    for c, camera in enumerate(cameras):
        remote = SimulatedWiimote(
            camera,
            sources,
            clock,
            np.random.default_rng(rng.integers(2**63)),
            sigma_px=sigma_px,
            realtime=realtime,
            faults=faults[c] if faults else None,
            phase_s=float(rng.uniform(0.0, 0.01)),
            history_size=TRUTH_REPORTS,
        )
        settings = DriverSettings(sensitivity=sensitivity, ir_format=ir_format, player_led=c + 1)
        driver = WiimoteDriver(remote, clock, settings, name=f"cam{c}")
        drivers.append(driver)
        remotes.append(remote)
    return drivers, remotes
