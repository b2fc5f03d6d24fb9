"""The dashboard without a browser, on the simulated system on a simulated clock: what it draws
and shows as the operator calibrates, tracks, previews and throws; the demo command."""

from __future__ import annotations

import re
import time

import numpy as np
import pytest

from wiithrow.app.cli.main import main
from wiithrow.app.session import Event, Operation, demo_target_base, simulated_session, throw_outcome
from wiithrow.web.panels import status_text


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


def _total(text: str) -> str:
    """The total of the first "error X mm" in `text` (the label's, the status's)."""
    found = re.search(r"error (\d+\.\d) mm", text)
    assert found, text
    return found.group(1)


def test_one_error_figure_in_one_unit_the_label_follows_measure_landing(dashboard):
    """The scene's label, the table, the status and the Throw folder say one figure per throw, in
    mm, with who measured it; after Measure landing every one says the new figure, and why it differs."""
    session = dashboard.session
    dashboard.refresh()
    record = session.history[-1]
    label = dashboard.scene._landing_label.text
    assert label.startswith(f"throw {record.index}: error ") and label.endswith("measured by the rig"), label
    row = next(line for line in dashboard.panels.table.content.splitlines() if line.startswith(f"| {record.index} |"))
    assert "measured by the rig" in dashboard.panels.table.content
    assert row.split("|")[5].strip().split(" / ")[2] == _total(label)
    measured = session.measure_landing()
    dashboard.refresh()
    label = dashboard.scene._landing_label.text
    assert label == f"throw {record.index}: {throw_outcome(measured)}", "the label follows Measure landing"
    assert label.endswith("measured anew by the rig (Measure landing)") and " cm" not in label
    row = next(line for line in dashboard.panels.table.content.splitlines() if line.startswith(f"| {record.index} |"))
    cell = row.split("|")[5].strip()
    assert cell.split(" / ")[2].split()[0] == _total(label) and "(measured anew)" in cell
    status = dashboard.panels.status.content
    assert f"measured anew by the rig: error {_total(label)} mm" in status and " cm" not in status
    assert "at the landing it measured" in status and "noise" in status, "why the figure changed"
    assert _total(dashboard.panels.throw_md.content) == _total(label)


def test_the_status_says_what_runs_and_on_what(dashboard):
    session = dashboard.session
    where = dashboard.panels.where
    assert where == "kinematic (simulated: the planner's own models) Mitsubishi PA-10"
    seen: list[str] = []

    def on_event(event: Event) -> None:
        if event is Event.PROGRESS or event is Event.OPERATION:
            seen.append(status_text(session.snapshot(), calibrated=True, where=where))

    session.subscribe(on_event)
    try:
        session.set_target(demo_target_base())
        assert session.align().converged
        session.plan_preview()
        n = len(session.history) + 1
        session.throw(session.preview.id)
    finally:
        session.unsubscribe(on_event)
    heads = [line.split(" · ")[0] for line in seen if not line.startswith("**Idle")]
    assert f"**Throw {n} running on {where}: throwing**" in heads, heads
    assert any(h.startswith(f"**Track target running on {where}: ") for h in heads), heads
    assert not [h for h in heads if h.endswith(": ...**") or "tracking: " in h], heads


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
    """One link at start, the operator's with its token; the guests' address described, not linked;
    nothing of viser's own (its banner of the bare address, "Server stopped")."""
    assert main(["demo", "--port", "0", "--duration", "0.5", "--no-calibrate"]) == 0
    out = capsys.readouterr()
    links = re.findall(r"\b(?:https?|wss?)://\S+", out.out + out.err)
    assert len(links) == 1, out.out + out.err
    link = re.fullmatch(r"http://127\.0\.0\.1:\d+/\?token=([A-Za-z0-9_-]{43})", links[0])
    assert link, links
    assert out.out.count(link.group(1)) == 1 and link.group(1) not in out.err, "the token is printed once"
    assert "guests (view only): the same address without the token" in out.out
    assert "viser" not in out.out + out.err
    assert "NOTE" not in out.err


def test_a_taken_port_is_one_line_and_exit_2(capsys):
    """A second demo on a taken port does not serve on the next one: one line, exit 2, before the
    world starts (the dashboard checks again once viser has bound, `web.handshake.PortTaken`)."""
    import socket

    from wiithrow.web.handshake import PortTaken
    from wiithrow.web.server import Dashboard

    with socket.socket() as taken:
        taken.bind(("127.0.0.1", 0))
        taken.listen()
        port = taken.getsockname()[1]
        assert main(["demo", "--port", str(port), "--duration", "0.5", "--no-calibrate"]) == 2
        out = capsys.readouterr()
        assert out.out == ""
        assert out.err.splitlines() == [
            f"wiithrow demo: port {port} is taken (another wiithrow?); --port N to choose another, "
            "--port 0 for any free port"
        ]
        session = simulated_session(seed=1, calibration=None, quiet=True)
        try:
            with pytest.raises(PortTaken, match=f"port {port} is taken"):
                Dashboard(session, port=port, analysis_process=False, derived_figures=False)
        finally:
            session.close()


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
