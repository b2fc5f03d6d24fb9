"""The dashboard without a browser, on the simulated system on a simulated clock: what it draws
and shows as the operator calibrates, tracks, previews and throws; the demo command."""

from __future__ import annotations

import re
import time

import numpy as np
import pytest

from wiithrow.app.cli.main import main
from wiithrow.app.session import Operation, demo_target_base, simulated_session


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
    p, states = dashboard.panels, dashboard.states
    assert states[Operation.CALIBRATE] == "" and states[Operation.TRACK] and states[Operation.PREVIEW]
    assert states[Operation.THROW]
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
    assert dashboard.states[Operation.TRACK] == ""
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
    assert dashboard.states[Operation.THROW] == ""
    dashboard.scene.animate_preview()
    record = session.throw(session.preview.id)
    dashboard.refresh()
    assert dashboard.states[Operation.THROW], "a preview is thrown once"
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
    assert "moved" in dashboard.states[Operation.PREVIEW]


def test_an_update_that_moves_nothing_keeps_the_preview(dashboard):
    """A drag handle's update at the target's own place (the handle follows the target) cleared the
    preview, so a confirmed throw found none."""
    session = dashboard.session
    session.set_target(demo_target_base())
    dashboard.refresh()
    assert session.align().converged
    preview = session.plan_preview()
    dashboard.refresh()
    dashboard._target_moved(dashboard.scene.target_drawn + 2e-4, None)
    assert session.preview is preview
    dashboard._target_moved(dashboard.scene.target_drawn + np.array([0.0, 0.05, 0.0]), None)
    assert session.preview is None


def test_demo_prints_the_operators_link_once(capsys):
    assert main(["demo", "--port", "0", "--duration", "0.5", "--no-calibrate"]) == 0
    out = capsys.readouterr()
    link = re.search(r"http://127\.0\.0\.1:\d+/\?token=([A-Za-z0-9_-]{43})", out.out)
    assert link, out.out
    assert out.out.count(link.group(1)) == 1 and link.group(1) not in out.err, "the token is printed once"
    assert "NOTE" not in out.err


def test_demo_beyond_loopback_needs_a_chosen_token(capsys, tmp_path, monkeypatch):
    monkeypatch.delenv("WIITHROW_TOKEN", raising=False)
    assert main(["demo", "--host", "0.0.0.0", "--port", "0", "--duration", "0.5", "--no-calibrate"]) == 2
    err = capsys.readouterr().err
    assert len(err.strip().splitlines()) == 1 and "--host 0.0.0.0" in err and "--token-file" in err
    token = tmp_path / "token"
    token.write_text("correct-horse-battery-staple\n")
    argv = ["demo", "--host", "0.0.0.0", "--port", "0", "--duration", "0.5", "--no-calibrate"]
    assert main([*argv, "--token-file", str(token)]) == 0
    out = capsys.readouterr()
    assert "correct-horse-battery-staple" not in out.out + out.err, "a service's token is not printed"
    assert "only holders of the operator token can move it" in out.err
    for bad, why in ((tmp_path / "missing", "cannot read"), (tmp_path, "cannot read")):
        assert main([*argv, "--token-file", str(bad)]) == 2
        assert why in capsys.readouterr().err
    token.write_text("short")
    assert main([*argv, "--token-file", str(token)]) == 2
    assert "too short" in capsys.readouterr().err


def test_the_demos_automatic_calibration_waits_for_an_operators_page():
    """Issue 21: `make demo` calibrated at start and was done before a slow browser (22 s) showed
    the page. It now starts when the first operator's page has connected (a guest's does not
    count), once, as the Calibrate button does; the terminal says it waits, then that it starts."""
    from wiithrow.app.cli.serving import WAITING, AutoCalibration
    from wiithrow.web.server import Dashboard

    session = simulated_session(seed=2, calibration=None, quiet=True)
    dash = Dashboard(session, port=0, default_poses=7, analysis_process=False, derived_figures=False)
    said: list[str] = []
    try:
        automatic = AutoCalibration(dash, 7, say=said.append)
        assert said == [WAITING.format(poses=7)] and "waiting for an operator's page to calibrate" in said[0]
        for _ in range(3):  # no page yet (or only guests'): nothing starts
            assert not automatic.poll()
        assert not session.busy and session.calibration_result is None and dash.runner.started == 0
        dash.clients.operator_seen.set()  # what an operator's page connecting sets (tests/web/test_browser_demo.py)
        assert automatic.poll() and said[-1].endswith("calibrating (7 poses)")
        assert not automatic.poll(), "once"
        dash.runner.join(timeout=120.0)
        assert session.calibration_result is not None and len(session.calibration_result.data) == 7
        assert dash.runner.started == 1
        none = AutoCalibration(dash, 0, say=said.append)  # --no-calibrate, --calibration
        dash.clients.operator_seen.set()
        assert not none.poll() and len(said) == 2
    finally:
        dash.close()
        session.close()
