"""A wand calibration drives the dashboard as a robot calibration does, with 2, 3 and 4 simulated
remotes: each remote's view, its frustum placed by the calibration, the tracked markers, the Wand
panel's coverage and result (without a browser, on a simulated clock)."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from wiithrow.app.rig.moving_markers import crossing_paths
from wiithrow.app.rig.waiting import pump
from wiithrow.app.session import simulated_session


@pytest.mark.parametrize("remotes", [2, 3, 4])
def test_a_wand_calibration_drives_the_dashboard(remotes):
    from wiithrow.web.server import Dashboard

    session = simulated_session(seed=90 + remotes, calibration=None, cameras=remotes, quiet=True)
    dashboard = Dashboard(session, port=0, analysis_process=False, derived_figures=False)
    try:
        dashboard.refresh()
        assert len(dashboard.panels.cameras.images) == remotes == len(dashboard.wand.coverage)
        assert "No wand calibration" in dashboard.wand.summary.content
        # the Wand panel's Start, as a click would (the session runs it in a worker thread)
        dashboard._on_wand(SimpleNamespace(client=None), 0.3, 15.0, "camera")
        dashboard.runner.join(120.0)
        dashboard._wand_every._last = -np.inf
        dashboard.refresh()
        s = session.snapshot()
        assert s.wand is not None and s.calibration is None and session.world.calibration.frame == "link1"
        assert "wand score" in dashboard.wand.summary.content
        assert "Calibrated with a wand" in dashboard.panels.calibration_md.content
        assert len(dashboard.scene._frustums) == remotes
        assert all(image.label.endswith("coverage") for image in dashboard.wand.coverage)
        # four markers in front of the rig are tracked and drawn
        session.world.hold(lambda t: crossing_paths(t - 1000.0))
        pump(session.world.clock, session.world.rig, 0.5, step_s=0.001)
        dashboard.refresh()
        ids, positions = dashboard.scene._markers_key
        assert len(ids) == 4
        seen_at = session.world.rig.latest_tracked().t
        truth = session.world.link1_to_base(crossing_paths(seen_at - 1000.0))
        nearest = np.min(np.linalg.norm(positions[:, None] - truth[None], axis=2), axis=1)
        assert nearest.max() < 0.006  # in base, where the scene draws them
    finally:
        dashboard.close()
        session.close()
