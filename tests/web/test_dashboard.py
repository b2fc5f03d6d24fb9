"""The dashboard without a browser, on the simulated system on a simulated clock: what it draws
and shows as the operator calibrates, tracks, previews and throws; the demo command."""

from __future__ import annotations

import time

import numpy as np
import pytest

from wiithrow.app.cli.main import main
from wiithrow.app.session import demo_target_base, simulated_session


@pytest.fixture(scope="module")
def dashboard():
    from wiithrow.web.server import Dashboard

    session = simulated_session(seed=1, calibration=None, quiet=True)
    session.set_target(demo_target_base())
    dash = Dashboard(session, port=0, default_poses=8, analysis_process=False)
    yield dash
    dash.close()
    session.close()


def test_before_calibration_the_nominal_rig_is_drawn_and_tracking_is_disabled(dashboard):
    dashboard.refresh()
    p = dashboard.panels
    assert not p.calibrate.disabled and p.track.disabled and p.preview.disabled and p.throw.disabled
    assert not p.stop.disabled
    assert "not calibrated" in p.status.content
    assert len(dashboard.scene._frustums) == 2
    assert dashboard.meter.count >= 1


def test_calibration_shows_its_errors_points_and_curves(dashboard):
    session = dashboard.session
    session.calibrate(8)
    dashboard.refresh()
    text = dashboard.panels.calibration_md.content
    assert "8 poses" in text and "Leave-one-out 3D error" in text and "Worst points" in text
    names = [node.name for node in dashboard.scene._calibration_nodes]
    assert "/link1/calibration/actual" in names and "/link1/calibration/residuals" in names
    assert not dashboard.panels.track.disabled
    end = time.monotonic() + 60.0
    while dashboard.figures_pending and time.monotonic() < end:
        time.sleep(0.2)
        dashboard.refresh()
    assert dashboard.figures_pending == 0
    assert dashboard.panels.loo_plot.visible and dashboard.panels.mono_plot.visible
    sizes, refined = dashboard.panels.loo_plot.data[0], dashboard.panels.loo_plot.data[1]
    assert sizes[-1] == 8 and np.isfinite(refined).all()


def test_preview_then_throw_are_drawn_and_tabled(dashboard):
    session = dashboard.session
    assert session.align().converged
    session.plan_preview()
    dashboard.refresh()
    assert dashboard.scene.ghost.visible and dashboard.panels.speed_plot.visible
    assert not dashboard.panels.throw.disabled
    dashboard.scene.animate_preview()
    record = session.throw(session.preview.id)
    dashboard.refresh()
    assert dashboard.panels.throw.disabled, "a preview is thrown once"
    assert f"| {record.index} |" in dashboard.panels.table.content
    assert dashboard.scene._landing.visible and not dashboard.scene.ghost.visible


def test_dragging_the_target_moves_it_and_asks_to_track_again(dashboard):
    session = dashboard.session
    dashboard.refresh()
    target = session.world.source_positions_base()[1]
    dashboard._target_moved(target + np.array([0.0, 0.15, -0.5]), None)  # below the floor: kept on it
    moved = session.world.source_positions_base()[1]
    assert np.allclose(moved, [target[0], target[1] + 0.15, 0.0])
    dashboard.refresh()
    assert dashboard.panels.preview.disabled and "moved" in dashboard.panels.preview.hint


def test_demo_prints_its_address_and_warns_when_exposed(capsys):
    assert main(["demo", "--port", "0", "--duration", "0.5", "--no-calibrate"]) == 0
    out = capsys.readouterr()
    assert "http://127.0.0.1:" in out.out and "WARNING" not in out.err
    assert main(["demo", "--host", "0.0.0.0", "--port", "0", "--duration", "0.5", "--no-calibrate"]) == 0
    assert "Anyone who can reach this port can move the robot" in capsys.readouterr().err
