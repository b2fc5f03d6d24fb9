"""The Library folder without a browser, on a simulated clock: the library in use and its versions,
what the learning did with the last throw, a click from no operator's browser starts nothing, an
operator's *Use this version* goes back (checked on the server), and a guest's controls say why."""

from __future__ import annotations

import dataclasses
from types import SimpleNamespace

import pytest

from tests.conftest import wait_for
from tests.helpers.sim_fixtures import target_at
from wiithrow.app.session import Operation, simulated_session
from wiithrow.app.throws.library_store import LibraryStore
from wiithrow.web.access import Role, Token
from wiithrow.web.controls import GUEST_REASON
from wiithrow.web.library_panel import KEEP_OLD, NO_FOLDER, USE_NEW, USE_VERSION, learning_line

TOKEN = Token("0123456789abcdef-library-token", "--token")


@pytest.fixture(scope="module")
def dashboard(tmp_path_factory):
    from wiithrow.web.server import Dashboard

    store = LibraryStore(tmp_path_factory.mktemp("lab") / "library")
    session = simulated_session(seed=4, calibration="true", quiet=True, store=store)
    dash = Dashboard(session, port=0, token=TOKEN, derived_figures=False, analysis_process=False)
    yield dash
    dash.close()
    session.close()


def _throw(session, distance: float, azimuth: float):
    session.set_target(target_at(distance, azimuth, 0.1))
    assert session.align().converged
    return session.throw(session.plan_preview().id)


def test_the_folder_shows_the_library_in_use_and_what_the_learning_did(dashboard):
    session, panel = dashboard.session, dashboard.training.library
    dashboard.refresh()
    text = panel.status.content
    assert "**In use**: the shipped library (not a version)" in text and str(session.library_store.folder) in text
    assert "no throw has joined yet" in text
    assert "**Calibration in use**" in text and session.calibration_fingerprint() in text
    record = _throw(session, 1.3, 0.1)
    dashboard.refresh()
    text = panel.status.content
    version = record.learned["version"]
    assert f"**In use**: version {version} (learning, " in text
    assert f"throw {record.index}: joined as version {version}, in use" in text
    assert f"| {version} |" in text and "| 1 |" in text  # the versions: the import, then the update
    # a refused throw: the folder says why
    said = dataclasses.replace(record, learned={"error": "the throw did not join the library: X"})
    refused = dataclasses.replace(session.snapshot(), history=(*session.history[:-1], said))
    assert f"throw {record.index}: refused: the throw did not join the library: X" in learning_line(refused)


def test_a_click_from_no_operators_browser_starts_nothing(dashboard):
    started, logged = dashboard.runner.started, dashboard.refusals.counts["message"]
    event = SimpleNamespace(client=None)
    panel = dashboard.training.library
    panel._clicked(event, Operation.LIBRARY_USE, 1)  # type: ignore[arg-type]
    panel._clicked(event, Operation.LIBRARY_CHOOSE, True)  # type: ignore[arg-type]
    assert dashboard.runner.started == started and dashboard.refusals.counts["message"] == logged + 2
    states = panel.states()
    assert states[USE_VERSION] == "" and states[USE_NEW] == states[KEEP_OLD] == dashboard.session.refusal(
        Operation.LIBRARY_CHOOSE
    )


def test_an_operator_goes_back_to_a_version_and_a_guest_is_told_why(dashboard):
    """Through real websockets: the operator's Use this version puts version 1 back in use; the
    guest's controls are disabled, saying why."""
    import viser
    from websockets.sync.client import connect

    from wiithrow.app.cli.bench import viser_client

    session, panel = dashboard.session, dashboard.training.library
    store = session.library_store
    assert store.in_use_record().id != 1
    before = set(dashboard.clients.roles)
    url = f"ws://127.0.0.1:{dashboard.port}/?token={TOKEN.value}"
    with connect(url, subprotocols=[f"viser-v{viser.__version__}"], max_size=None) as operator:
        operator.send(viser_client.camera_message())
        new = wait_for(lambda: set(dashboard.clients.roles) - before, 10.0, "the client to connect")
        client_id = next(iter(new))
        inputs = wait_for(lambda: panel._inputs.get(client_id), 10.0, "its library inputs")
        client = dashboard.server.get_clients()[client_id]
        inputs.version.value = 1
        panel._clicked(SimpleNamespace(client=client), Operation.LIBRARY_USE, 1)  # type: ignore[arg-type]
        wait_for(lambda: not dashboard.runner.running and not session.busy, 20.0, "the operation to end")
        assert store.in_use_record().id == 1 and session.library_version.id == 1
        assert session.library.to_dict() == store.load(1)[1].to_dict()
        dashboard.refresh()
        assert "**In use**: version 1 (import, 25 throws" in panel.status.content
    guest_url = f"ws://127.0.0.1:{dashboard.port}/"
    origin = f"http://127.0.0.1:{dashboard.port}"  # a browser's page says where it comes from
    with connect(guest_url, origin=origin, subprotocols=[f"viser-v{viser.__version__}"], max_size=None) as guest:
        guest.send(viser_client.camera_message())
        new = wait_for(
            lambda: {c for c, r in dashboard.clients.roles.items() if r is Role.GUEST} - before, 10.0, "the guest"
        )
        inputs = wait_for(lambda: panel._inputs.get(next(iter(new))), 10.0, "the guest's library inputs")
        assert all(b.disabled and GUEST_REASON in b.hint for b in inputs.buttons.values())
        assert inputs.version.disabled and GUEST_REASON in inputs.reasons.content


def test_without_a_library_folder_use_this_version_says_why():
    from wiithrow.web.library_panel import LibraryPanel

    session = simulated_session(seed=4, calibration="true", quiet=True)
    panel = LibraryPanel.__new__(LibraryPanel)
    panel.session = session
    assert panel.states()[USE_VERSION] == NO_FOLDER
    session.close()
