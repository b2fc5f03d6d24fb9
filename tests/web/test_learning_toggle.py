"""The dashboard's Keep learning toggle (issue 22, item 3): operators only, checked on the server;
refused with the session's reason while an operation runs; every box follows the session."""

from types import SimpleNamespace

import pytest

from wiithrow.app.session import Operation, demo_target_base, simulated_session
from wiithrow.web.access import Role
from wiithrow.web.learning_toggle import LearningToggle


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
    client = SimpleNamespace(
        client_id=client_id, add_notification=lambda title, body, **_: told.append(f"{title}: {body}")
    )
    dashboard.clients.roles[client_id] = role
    return client, told


def test_only_an_operator_changes_it_and_not_while_an_operation_runs(dashboard):
    toggle = LearningToggle(dashboard)
    session = dashboard.session
    assert session.learning
    guest, guest_told = _client(dashboard, 201, Role.GUEST)
    assert not toggle.change(guest, False) and session.learning and guest_told
    assert any(r.reason == "Keep learning from a guest client: refused" for r in dashboard.refusals.recent)

    operator, told = _client(dashboard, 202, Role.OPERATOR)
    with session._operation(Operation.HOME):  # an operation runs: the change is refused with its reason
        assert not toggle.change(operator, False)
    assert session.learning and told and "busy: moving the arm home" in told[-1]
    assert toggle.change(operator, False) and not session.learning
    assert toggle.change(operator, True) and session.learning
