"""The dashboard's Record toggle (issue 14, part A): operators only, checked on the server; one
click starts a recording of the session into a new file, the next closes it."""

import time
from types import SimpleNamespace

import pytest
from mcap.reader import make_reader

from wiithrow.app.rig.waiting import pump
from wiithrow.app.session import demo_target_base, simulated_session
from wiithrow.web.access import Role
from wiithrow.web.recording_toggle import RecordToggle


@pytest.fixture()
def dashboard():
    from wiithrow.web.server import Dashboard

    session = simulated_session(seed=2, calibration="true", quiet=True)
    session.set_target(demo_target_base())
    dash = Dashboard(session, port=0, analysis_process=False, derived_figures=False)
    yield dash
    dash.close()
    session.close()


def _client(dashboard, client_id: int, role: Role):
    told: list[str] = []
    client = SimpleNamespace(client_id=client_id, add_notification=lambda title, body, **_: told.append(title))
    dashboard.clients.roles[client_id] = role
    return client, told


def test_a_guest_cannot_record_and_an_operator_toggles_it(dashboard, tmp_path):
    toggle = RecordToggle(dashboard, tmp_path / "recordings")
    guest, guest_told = _client(dashboard, 101, Role.GUEST)
    toggle.on_click(SimpleNamespace(client=guest))
    assert not toggle.active() and not (tmp_path / "recordings").exists() and guest_told == ["View only"]
    assert any(r.reason == "Record from a guest client: refused" for r in dashboard.refusals.recent)

    operator, _ = _client(dashboard, 102, Role.OPERATOR)
    toggle.on_click(SimpleNamespace(client=operator))
    assert toggle.active()
    path = toggle.recorder.path
    pump(dashboard.world.clock, dashboard.world.rig, 1.0, step_s=0.001)
    toggle.on_click(SimpleNamespace(client=operator))
    assert not toggle.active() and toggle.recorder is None
    with path.open("rb") as f:
        summary = make_reader(f).get_summary()
    counts = {c.topic: summary.statistics.channel_message_counts[i] for i, c in summary.channels.items()}
    assert 90 <= counts["/markers"] <= 110 and counts["/arm/joints"] >= 40 and counts["/wiimote/1/reports"] >= 1
    toggle.close()


def test_an_operators_browser_clicks_record_then_stop_recording(dashboard, tmp_path):
    """Through the websocket, as a browser: the button is there, says Stop recording while it records."""
    from wiithrow.app.cli.bench.soak import _Operator

    toggle = RecordToggle(dashboard, tmp_path)
    dashboard.session.start()
    dashboard.start()
    operator = _Operator(dashboard)
    try:
        assert operator.click("Record", 20.0)
        deadline = time.monotonic() + 10
        while not toggle.active() and time.monotonic() < deadline:
            time.sleep(0.05)
        assert toggle.active()
        time.sleep(0.5)
        assert operator.click("Stop recording", 20.0)
        while toggle.active() and time.monotonic() < deadline + 10:
            time.sleep(0.05)
        assert not toggle.active()
    finally:
        operator.close()
    files = list(tmp_path.glob("wiithrow-*.mcap"))
    assert len(files) == 1
    with files[0].open("rb") as f:
        summary = make_reader(f).get_summary()
    assert summary is not None and summary.statistics.message_count > 10
