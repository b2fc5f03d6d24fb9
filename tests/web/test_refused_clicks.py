"""A button's enabled state and the server's acceptance of its click are one function
(`Session.refusal`): without a browser, a dashboard on the simulated system (simulated clock,
not calibrated) spoken to through a real websocket with the operator token. A forged click on a
disabled button (Track target before a calibration: the issue's markers-from case, where a click
ran the alignment while the button said "calibrate first") starts nothing and is answered with
the very text the page shows beside the button; a guest's page says guest."""

from __future__ import annotations

import time

import pytest
import viser
from websockets.sync.client import connect

from tests.conftest import wait_for
from wiithrow.app.cli.bench import viser_client
from wiithrow.app.session import Operation
from wiithrow.web.access import Role, Token
from wiithrow.web.controls import GUEST_BANNER, GUEST_REASON, reasons_text

TOKEN = Token("0123456789abcdef-refusal-token", "--token")
PROTOCOL = f"viser-v{viser.__version__}"


@pytest.fixture(scope="module")
def dashboard():
    from wiithrow.app.session import demo_target_base, simulated_session
    from wiithrow.web.server import Dashboard

    session = simulated_session(seed=4, calibration=None, quiet=True)
    session.set_target(demo_target_base())
    dash = Dashboard(session, port=0, token=TOKEN, analysis_process=False, derived_figures=False)
    dash.refresh()
    yield dash
    dash.close()
    session.close()


def new_client(dashboard, before: set[int]) -> int:
    new = wait_for(lambda: set(dashboard.clients.roles) - before, 10.0, "the client to connect")
    assert len(new) == 1
    return new.pop()


def received_messages(connection, seconds: float) -> list[dict]:
    """Every message the server sent `connection` within `seconds` (decoded, buffers left out)."""
    seen: list[dict] = []
    end = time.monotonic() + seconds
    while time.monotonic() < end:
        try:
            data = connection.recv(timeout=max(0.05, end - time.monotonic()))
        except TimeoutError:
            break
        if isinstance(data, bytes):
            seen += viser_client.decode_window(data)
    return seen


def received_text(connection, seconds: float) -> str:
    """Everything the server sent `connection` within `seconds`, as text."""
    return "\n".join(repr(m) for m in received_messages(connection, seconds))


def test_the_buttons_show_what_session_refusal_says(dashboard):
    session = dashboard.session
    for op, why in dashboard.states.items():
        assert why == (session.refusal(op) or ""), op
    assert dashboard.states[Operation.TRACK].startswith("calibrate first")
    assert dashboard.states[Operation.CALIBRATE] == ""


def test_a_forged_click_whose_precondition_fails_is_refused_with_the_buttons_text(dashboard):
    session = dashboard.session
    url = f"ws://127.0.0.1:{dashboard.port}/?token={TOKEN.value}"
    before = set(dashboard.clients.roles)
    with connect(url, subprotocols=[PROTOCOL], max_size=None) as operator:
        operator.send(viser_client.camera_message())
        client_id = new_client(dashboard, before)
        assert dashboard.clients.roles[client_id] is Role.OPERATOR
        mine = next(c for c in dashboard.clients.controls() if c.client.client_id == client_id)
        wait_for(lambda: mine.track.disabled, 5.0, "Track target to be disabled")
        why = session.refusal(Operation.TRACK)
        assert why and mine.track.disabled and why in mine.track.hint
        # the reason is in the page, not only in the hover hint: the Throw folder's line
        line = mine.reasons["throw"]
        assert line.visible and "*Track target*" in line.content and why in line.content
        assert line.content.count(why) == 1, "a reason that holds back several buttons is said once"
        assert line.content == reasons_text(
            dashboard.states,
            (Operation.TRACK, Operation.PREVIEW, Operation.THROW, Operation.MEASURE_LANDING, Operation.HOME),
        )
        received_text(operator, 0.5)  # what the connection was sent so far
        started, logged = dashboard.runner.started, dashboard.refusals.counts["message"]
        q0 = session.world.arm.state().q.copy()
        operator.send(viser_client.click(mine.track._impl.uuid))  # a client's click on its disabled button
        wait_for(lambda: dashboard.refusals.counts["message"] > logged, 5.0, "the click to be refused")
        told = received_text(operator, 1.0)
    assert dashboard.runner.started == started and not session.busy, "the refused click started something"
    assert (session.world.arm.state().q == q0).all()
    assert f"Track target refused: {why}" in dashboard.refusals.recent[-1].reason
    assert why in told, "the server answers the click with the button's own reason"


def test_a_guest_sees_in_the_page_that_they_are_a_guest(dashboard):
    origin = f"http://127.0.0.1:{dashboard.port}"
    before = set(dashboard.clients.roles)
    with connect(f"ws://127.0.0.1:{dashboard.port}", subprotocols=[PROTOCOL], origin=origin) as guest:
        guest.send(viser_client.camera_message())
        client_id = new_client(dashboard, before)
        assert dashboard.clients.roles[client_id] is Role.GUEST
        mine = next(c for c in dashboard.clients.controls() if c.client.client_id == client_id)
        assert mine.banner is not None and mine.banner.content == GUEST_BANNER and "guest" in GUEST_BANNER
        for folder, line in mine.reasons.items():
            assert line.visible and line.content == GUEST_REASON, folder
        assert all(b.disabled for b in (mine.calibrate, mine.track, mine.preview, mine.throw, mine.measure, mine.home))
        sent = received_text(guest, 1.0)
        assert "You are a guest" in sent and GUEST_REASON in sent
