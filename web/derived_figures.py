"""The figures the dashboard derives after a calibration, started and shown when they are done.

Owns `DerivedFigures`: when the calibration changes, `start` asks `wiithrow.web.analysis` (in
another process) for the leave-one-out error against the number of points (when at least 7
poses were measured) and, in simulation, for the mono method against the stereo rig (Fig. 6 of
the paper, on a simulated twin of the world); `apply`, called by every refresh, hands each result
that has arrived to the panels (a failed one becomes a notification).
"""

from __future__ import annotations

from collections.abc import Callable
from concurrent.futures import Future
from typing import Any

import numpy as np

from wiithrow.app.session import SessionSnapshot
from wiithrow.app.worlds import RigWorld
from wiithrow.web.analysis import Analysis
from wiithrow.web.panels import Panels

Notify = Callable[[Any, str, str, Any], None]  # (client or None for all, title, body, colour name)


class DerivedFigures:
    """The derived figures of one dashboard (see the module docstring)."""

    def __init__(self, analysis: Analysis, world: RigWorld, *, enabled: bool = True) -> None:
        self.analysis = analysis
        self.world = world
        self.enabled = enabled
        self._pending: list[tuple[str, Future[Any]]] = []  # (kind, its result)

    def __len__(self) -> int:
        """Figures still being computed."""
        return len(self._pending)

    def start(self, s: SessionSnapshot) -> None:
        """Forget what was pending and start the figures of the calibration now."""
        self._pending = []
        if not self.enabled:
            return
        c = s.calibration
        if c is not None and len(c.data) >= 7:
            self._pending.append(("loo", self.analysis.loo_curve(c.data.positions, c.data.image)))
        if self.world.simulated and self.world.calibration is not None:
            self._pending.append(("mono", self.analysis.mono_vs_stereo(self.world.settings, self.world.calibration)))

    def apply(self, panels: Panels, notify: Notify) -> None:
        """Show the figures that are done; keep waiting for the others."""
        if not self._pending:
            return
        remaining = []
        for kind, future in self._pending:
            if not future.done():
                remaining.append((kind, future))
                continue
            try:
                result = future.result()
            except Exception as exc:
                notify(None, "Figure not computed", f"{kind}: {exc}", "yellow")
                continue
            if kind == "loo":
                panels.show_loo_curve(result.sizes, 1e3 * result.refined_m, 1e3 * result.paper_m)
            else:
                panels.show_mono_vs_stereo(
                    result.angle_deg, 1e3 * result.mono_m, 1e3 * result.stereo_m, mono_note(result)
                )
        self._pending = remaining


def mono_note(result: Any) -> str:
    """The text under the mono-against-stereo figure."""
    n = len(result.angle_deg)
    if not n:
        return "No angle measured."
    return (
        f"Depth error of the midpoint of two beacons 0.15 m apart, measured by the mono method "
        f"(one camera, known distance) and by the stereo rig, while the hand turns the beacon line "
        f"out of cam0's image plane ({n} angles, simulated twin of this rig). Mono at "
        f"{result.angle_deg[-1]:.0f}°: {1e3 * result.mono_m[-1]:.0f} mm; "
        f"stereo: {1e3 * np.nanmedian(result.stereo_m):.1f} mm (median)."
    )
