"""The operator chooses whose markers move the arm (`serve --markers-from` with no source named):
the session refuses Track target until a publisher is followed, saying who asks to be followed;
the dashboard's Marker source folder shows the publisher (its Zenoh id, stream, host, pid and
command), a guest's Follow is refused on the server, and an operator's click follows it. Without a
browser: a dashboard on a `HardwareWorld` built as `serve --markers-from` builds it, spoken to
through real websockets, and the real publisher in another process
(`tests.helpers.steady_publisher`)."""

from __future__ import annotations

import numpy as np
import pytest
import viser
from websockets.sync.client import connect

from tests.app.test_rogue_publishers import Steady, _rogue, _sent
from tests.conftest import wait_for
from wiithrow.app.cli.bench import viser_client
from wiithrow.app.cli.bench.publish import free_port
from wiithrow.app.errors import AppError
from wiithrow.app.network.zenoh_session import LOCAL_PORT_ENV, open_session
from wiithrow.app.session import Operation, Session
from wiithrow.app.settings import Settings
from wiithrow.app.worlds.hardware import HardwareWorld
from wiithrow.app.worlds.remote import markers_from
from wiithrow.clock import SystemClock
from wiithrow.web.access import Role, Token
from wiithrow.web.controls import GUEST_REASON, button_states
from wiithrow.web.source_panel import NOBODY_ASKS, SourcePanel, candidate_label

TOKEN = Token("0123456789abcdef-source-token", "--token")
PROTOCOL = f"viser-v{viser.__version__}"
DEADLINE_S = 30.0


@pytest.fixture
def served(monkeypatch):
    """A session on another host's markers (as `serve --markers-from wiithrow/lab` builds it, with a
    simulated arm driver), its rig loop running, and the real publisher in another process."""
    monkeypatch.setenv(LOCAL_PORT_ENV, str(free_port()))
    zenoh_session = open_session(None)
    settings = Settings().replace(arm_driver="tests.app.test_hardware_world:make_arm")
    world = HardwareWorld(settings, source=markers_from(zenoh_session, "wiithrow/lab", settings, SystemClock()))
    session = Session(world, rng=np.random.default_rng(0))
    world.rig.notices.subscribe(session.tell)  # what `serve` does (`MarkersFrom.tell`)
    real = Steady("local", 120.0)
    session.start()
    yield session, real
    real.kill()
    session.close()
    zenoh_session.close()


def test_track_is_refused_until_the_operator_confirms_a_publisher(served):
    session, real = served
    rig = session.world.rig
    wait_for(lambda: rig.candidates(), DEADLINE_S, "the publisher to ask to be followed")
    why = wait_for(lambda: session.refusal(Operation.TRACK), DEADLINE_S, "Track target's refusal")
    assert why.startswith("no marker source followed yet: ") and real.stream in why, why
    assert "confirm one on the dashboard" in why and "\n" not in why
    assert session.refusal(Operation.MEASURE_LANDING) == session.refusal(Operation.TRACK)
    with pytest.raises(AppError, match="does not ask to be followed now"):
        session.follow_source("0123", "4567")  # not a publisher that asks: nothing changes
    assert rig.followed() is None
    notice = session.follow_source(real.source, real.stream)
    assert notice.endswith("(confirmed by the operator)") and f"pid {real.pid}" in notice
    assert session.last_message.endswith(notice)  # told on the dashboard's status line
    followed = rig.followed()
    assert followed is not None and (followed.source, followed.stream) == (real.source, real.stream)
    assert session.refusal(Operation.TRACK) is None
    wait_for(lambda: rig.stale_reason() is None, DEADLINE_S, "its markers to be fresh")


def test_the_dashboard_shows_the_publisher_and_only_an_operators_click_follows_it(served):
    from wiithrow.web.server import Dashboard

    session, real = served
    rig = session.world.rig
    dashboard = Dashboard(session, port=0, token=TOKEN, analysis_process=False, derived_figures=False)
    panel = SourcePanel(dashboard)
    rogue = None
    try:
        # a rogue without the secret beside it: never shown
        rogue = _rogue("local", "other_source", 120.0, 2.0, 0.4, 0.3)
        url = f"ws://127.0.0.1:{dashboard.port}"
        with (
            connect(f"{url}/?token={TOKEN.value}", subprotocols=[PROTOCOL], max_size=None) as operator,
            connect(url, subprotocols=[PROTOCOL], origin=f"http://127.0.0.1:{dashboard.port}") as guest,
        ):
            operator.send(viser_client.camera_message())
            guest.send(viser_client.camera_message())
            wait_for(lambda: len(panel.controls) == 2, DEADLINE_S, "both clients' controls")
            mine = next(c for c in panel.controls.values() if c.role is Role.OPERATOR)
            theirs = next(c for c in panel.controls.values() if c.role is Role.GUEST)
            # no publisher asks yet, or one does: the operator's button says which
            wait_for(
                lambda: not mine.follow.disabled, DEADLINE_S, "Follow to be enabled", explain=lambda: mine.follow.hint
            )
            label = candidate_label(rig.candidates()[0])
            assert tuple(mine.publisher.options) == (label,) and mine.publisher.value == label
            assert f"pid {real.pid}" in label and real.stream in label
            text = panel.text.content
            assert "**No publisher followed yet**" in text and real.stream in text and f"| {real.pid} |" in text
            assert "steady_publisher" in text
            # a guest sees it, cannot press it, and a forged click is refused on the server
            assert theirs.follow.disabled and GUEST_REASON in theirs.follow.hint and theirs.reason.visible
            logged = dashboard.refusals.counts["message"]
            assert not panel.follow(theirs.client, label)
            assert dashboard.refusals.counts["message"] == logged + 1 and rig.followed() is None
            # Track target says why not, in the page as everywhere
            assert button_states(session)[Operation.TRACK].startswith("no marker source followed yet")
            # the operator's click
            operator.send(viser_client.click(mine.follow._impl.uuid))
            wait_for(lambda: rig.followed() is not None, DEADLINE_S, "the publisher to be followed")
            wait_for(lambda: "**Following**" in panel.text.content, DEADLINE_S, "the folder to say it")
            wait_for(lambda: mine.follow.disabled, DEADLINE_S, "Follow to be disabled: nobody else asks")
            assert NOBODY_ASKS in mine.follow.hint and NOBODY_ASKS in mine.reason.content
        rogue_sent = _sent(rogue)
    finally:
        if rogue is not None and rogue.poll() is None:
            rogue.kill()
        panel.close()
        dashboard.close()
    followed = rig.followed()
    assert followed is not None and (followed.source, followed.stream) == (real.source, real.stream)
    assert button_states(session)[Operation.TRACK] == ""
    assert 0 < rig.refused["unauthenticated"] <= rogue_sent and "r0gue" not in panel.text.content
