"""What one connection may cost the dashboard (`wiithrow.web.limits`, `wiithrow.web.wire`, applied
by `wiithrow.web.handshake`), and the operator's cookie over real sockets: a message over the size
limit closes its connection (1009); a nested or malformed message is one line, never a traceback;
a flood is read at the connection's rate (counts bounded, no timing asserted); 300 Stops stop 300
times and notify once; guests past the cap get 503; the link's token is redirected away.
"""

from __future__ import annotations

import http.client
import logging
import socket
import struct
import threading
import time

import msgspec
import pytest
from websockets.exceptions import ConnectionClosedError, InvalidStatus
from websockets.sync.client import connect

from tests.conftest import wait_for
from tests.web.test_access import PROTOCOL, TOKEN
from wiithrow.app.cli.bench import viser_client
from wiithrow.app.cli.bench.guest_flood import flood_messages, nested
from wiithrow.web.access import Role, admit_message
from wiithrow.web.limits import Burst, Limits, TokenBucket
from wiithrow.web.wire import decode_client_message

# -- the tools ------------------------------------------------------------------------------------------


def test_a_token_bucket_lets_a_burst_through_then_paces_at_its_rate():
    now = [0.0]
    bucket = TokenBucket(20.0, 40, clock=lambda: now[0])
    assert [bucket.delay() for _ in range(40)] == [0.0] * 40
    assert bucket.delay() == pytest.approx(1 / 20)  # the 41st waits for its token
    now[0] += 1.0  # 20 tokens later (one of them already owed)
    assert [bucket.delay() for _ in range(19)] == [0.0] * 19 and bucket.delay() > 0
    now[0] += 100.0
    assert sum(bucket.delay() == 0.0 for _ in range(100)) == 40, "never more than the burst saved up"
    with pytest.raises(ValueError):
        TokenBucket(0.0, 1)
    taker = TokenBucket(1.0, 2, clock=lambda: now[0])
    assert taker.take() and taker.take() and not taker.take() and not taker.take()
    now[0] += 1.0
    assert taker.take(), "a refusal takes nothing: the next token comes on time"


def test_a_burst_is_one_event_however_long_it_goes_on():
    now = [0.0]
    burst = Burst(2.0, clock=lambda: now[0])
    firsts = []
    for _ in range(3000):  # 3 000 presses in 5 s
        firsts.append(burst.first())
        now[0] += 5.0 / 3000
    assert sum(firsts) == 1 and burst.count == 3000
    now[0] += 2.0
    assert burst.first() and burst.count == 1, "a press after a quiet spell is a new burst"
    with pytest.raises(ValueError):
        Limits(max_guests=-1)


def test_the_size_limit_fits_the_pages_messages_many_times():
    limits = Limits()
    largest = max(len(viser_client.camera_message()), len(viser_client.click("0" * 36)))
    assert limits.max_message_bytes >= 1024 and largest * 50 <= limits.max_message_bytes <= 64 * 1024


# -- decoding that cannot recurse without bound ---------------------------------------------------------


def test_nested_and_malformed_messages_are_one_line_never_an_exception():
    deep_value = viser_client.encode({"type": "GuiUpdateMessage", "uuid": "x"})
    deep_value = (
        bytes([deep_value[0] + 1]) + deep_value[1:] + msgspec.msgpack.encode("updates") + b"\x91" * 5000 + b"\x01"
    )
    cases = {
        "nested before the type (2 KB)": nested(2000),
        "nested 100 000 deep before the type": nested(100_000),
        "nested in a value": deep_value,
        "a camera without its fields": viser_client.encode({"type": "ViewerCameraMessage"}),
        "a NaN camera": viser_client.encode({**viser_client.CAMERA, "fov": float("nan")}),
        "an infinite drag": viser_client.encode(
            {"type": "TransformControlsUpdateMessage", "name": "/h", "wxyz": [1, 0, 0, 0], "position": [1e300, 0, 0]}
        ),
        "an unknown field": viser_client.encode({**viser_client.CAMERA, "extra": 1}),
        "an unknown type": viser_client.encode({"type": "FileTransferStartUpload", "uuid": "x"}),
        "a long string": viser_client.click("x" * 5000),
        "a list value": viser_client.encode({"type": "GuiUpdateMessage", "uuid": "x", "updates": {"value": [1]}}),
        "truncated": viser_client.camera_message()[:40],
    }
    for what, raw in cases.items():
        for role in Role:
            why = admit_message(role, raw, "x")
            assert isinstance(why, str) and why and "\n" not in why and len(why) < 300, (what, why)
    assert "recursion limit" in admit_message(Role.OPERATOR, nested(2000), "x")
    assert "unknown field `extra`" in admit_message(Role.OPERATOR, cases["an unknown field"], "x")
    # what the page sends still decodes, and to what viser decodes too
    assert type(decode_client_message(viser_client.camera_message())).__name__ == "ViewerCameraMessage"
    assert msgspec.msgpack.decode(viser_client.click("x"))["updates"] == {"value": True}


# -- a dashboard spoken to through sockets ------------------------------------------------------------------


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


def guest(dashboard):
    return connect(
        f"ws://127.0.0.1:{dashboard.port}",
        subprotocols=[PROTOCOL],
        origin=f"http://127.0.0.1:{dashboard.port}",
        max_size=None,
    )


def operator(dashboard):
    return connect(f"ws://127.0.0.1:{dashboard.port}/?token={TOKEN.value}", subprotocols=[PROTOCOL], max_size=None)


def test_a_message_over_the_size_limit_closes_its_connection_and_is_logged(dashboard):
    limit = dashboard._gatekeeper.limits.max_message_bytes
    before = dashboard.refusals.counts["message"]
    with guest(dashboard) as g:
        g.send(viser_client.camera_message())
        g.send(b"\x00" * (limit // 2))  # under the limit: refused by the schema, the connection stays
        g.send(viser_client.camera_message())
        wait_for(lambda: dashboard.refusals.counts["message"] >= before + 1, 5.0, "the refusal")
        g.send(b"\x00" * (limit + 1))
        with pytest.raises(ConnectionClosedError) as closed:
            while True:
                g.recv(timeout=5.0)
    assert closed.value.rcvd is not None and closed.value.rcvd.code == 1009
    wait_for(lambda: f"over {limit} bytes" in dashboard.refusals.recent[-1].reason, 5.0, "the log line")


@pytest.fixture
def own_dashboard():
    """A dashboard of its own: a flooding connection is read at its rate after its sender is gone
    (until websockets' keepalive closes it), which the other tests' counts must not see."""
    from wiithrow.app.session import simulated_session
    from wiithrow.web.server import Dashboard

    session = simulated_session(seed=5, calibration=None, quiet=True)
    dash = Dashboard(session, port=0, token=TOKEN, analysis_process=False, derived_figures=False)
    yield dash
    dash.close()
    session.close()


def test_a_flood_of_nested_and_refused_messages_is_logged_in_lines_read_at_its_rate_and_stop_still_works(
    own_dashboard, caplog, capfd
):
    dashboard = own_dashboard
    limits = dashboard._gatekeeper.limits
    stop_uuid = dashboard._gatekeeper.stop_uuid
    # every kind the bench floods with but Stop (whose presses would go on being read after the test)
    messages = [m for m in flood_messages(stop_uuid) if m != viser_client.click(stop_uuid)]
    assert sum(admit_message(Role.GUEST, m, stop_uuid) is not None for m in messages) == 3
    before, stops = dashboard.refusals.counts["message"], dashboard.stops
    with caplog.at_level(logging.DEBUG), guest(dashboard) as g:
        g.send(viser_client.camera_message())
        stop_sending = threading.Event()

        def flood() -> None:
            i = 0
            while not stop_sending.is_set() and i < 2000:
                try:
                    g.send(messages[i % len(messages)])
                except Exception:
                    return
                i += 1

        sender = threading.Thread(target=flood, daemon=True)
        t0 = time.monotonic()
        sender.start()
        time.sleep(1.5)
        read = dashboard.refusals.counts["message"] - before
        elapsed = time.monotonic() - t0
        # read at the refused rate: at most the burst and the rate's worth (a few log lines of the
        # throttle itself on top), however fast the guest sends
        assert 0 < read <= limits.refused_burst + limits.refused_per_s * elapsed + 5, read
        assert dashboard._gatekeeper.throttled > 0
        stop_sending.set()
        # the guest vanishes mid-flood, its connection reset: its sender is blocked in a send the
        # server reads at the refused rate (a backlog of seconds to drain, in this test and then in
        # the dashboard's teardown)
        g.socket.setsockopt(socket.SOL_SOCKET, socket.SO_LINGER, struct.pack("ii", 1, 0))
        g.socket.shutdown(socket.SHUT_RDWR)
        sender.join(timeout=10.0)
        assert not sender.is_alive()
    # the server's records (the guest's own connection says it could not send: the test reset it)
    records = [
        r for r in caplog.records if r.name != "websockets.client" and (r.exc_info or "Traceback" in r.getMessage())
    ]
    assert not records, records[0].getMessage()
    assert "Traceback" not in capfd.readouterr().err
    ours = [r for r in caplog.records if r.name == "wiithrow.web.access"]
    assert len(ours) <= 2 * 10 + 2, "the refusal log's rate limit holds"
    # the connection survived it all: the next guest's Stop stops
    with guest(dashboard) as g:
        g.send(viser_client.camera_message())
        g.send(viser_client.click(dashboard._gatekeeper.stop_uuid))
        wait_for(lambda: dashboard.stops >= stops + 1, 10.0, "the Stop after the flood")


def stop_notifications(connection, quiet_s: float = 1.5) -> int:
    """How many Stop notifications a connection was sent (`stop_texts`)."""
    return len(stop_texts(connection, quiet_s))


def test_300_stops_from_a_guest_all_stop_and_the_guest_is_told_once_that_nothing_ran(dashboard):
    """Nothing runs and the arm rests: every press stops (cancels, brakes), one notification per
    burst goes to the guest who pressed ("nothing was running"), and none to the operator, whom
    a stop of nothing concerns not."""
    dashboard._gatekeeper.stop_burst = Burst(dashboard._gatekeeper.limits.stop_quiet_s)  # no earlier burst
    with operator(dashboard) as op, guest(dashboard) as g:
        op.send(viser_client.camera_message())
        g.send(viser_client.camera_message())
        stop_notifications(op, 1.0)  # the scene
        stops = dashboard.stops
        press = viser_client.click(dashboard._gatekeeper.stop_uuid)
        for _ in range(300):
            g.send(press)
        wait_for(lambda: dashboard.stops >= stops + 300, 30.0, "every Stop")
        assert dashboard.stops == stops + 300
        assert stop_notifications(op) == 0
        assert stop_notifications(g) == 1
    assert "Stop pressed by a guest: nothing was running" in dashboard.session.snapshot().message


def stop_texts(connection, quiet_s: float = 1.5) -> list[str]:
    """The bodies of the Stop notifications a connection was sent, read until it is sent nothing else
    they count for `quiet_s` (the scene and its refreshes are skipped)."""
    bodies: list[str] = []
    end = time.monotonic() + quiet_s
    while time.monotonic() < end:
        try:
            data = connection.recv(timeout=0.2)
        except TimeoutError:
            continue
        if isinstance(data, bytes) and len(data) >= 16:
            for m in viser_client.decode_window(data):
                if m.get("type") == "NotificationShowMessage" and m.get("props", {}).get("title") == "Stop":
                    bodies.append(m["props"]["body"])
                    end = time.monotonic() + quiet_s
    return bodies


def test_a_guests_stop_of_a_moving_arm_says_a_guest_pressed_it(dashboard, monkeypatch):
    """Something ran (here: the arm moving, as a Home or a throw moves it): every browser is told
    that a guest pressed Stop, and the session's message names the guest, not "the operator"."""
    dashboard._gatekeeper.stop_burst = Burst(dashboard._gatekeeper.limits.stop_quiet_s)  # no earlier burst
    monkeypatch.setattr(dashboard.session.world.arm, "is_moving", lambda: True)
    with operator(dashboard) as op, guest(dashboard) as g:
        op.send(viser_client.camera_message())
        g.send(viser_client.camera_message())
        stop_notifications(op, 1.0)  # the scene
        stops = dashboard.stops
        g.send(viser_client.click(dashboard._gatekeeper.stop_uuid))
        wait_for(lambda: dashboard.stops == stops + 1, 10.0, "the guest's Stop")
        (body,) = stop_texts(op)
        assert body.startswith("A guest pressed Stop: the running operation is cancelled"), body
    assert dashboard.session.snapshot().message == "stopped by a guest"


def test_guests_past_the_cap_get_503_and_a_free_place_is_taken_again(dashboard):
    keeper = dashboard._gatekeeper
    keeper.limits, default = Limits(max_guests=2), keeper.limits
    try:
        wait_for(lambda: keeper.guests() == 0, 10.0, "the other tests' guests to leave")
        first, second = guest(dashboard), guest(dashboard)
        with pytest.raises(InvalidStatus, match="503"):
            guest(dashboard).close()
        with operator(dashboard):  # operators are not counted
            pass
        assert "2 guests are connected already" in dashboard.refusals.recent[-1].reason
        first.close()
        wait_for(lambda: keeper.guests() == 1, 10.0, "the place to be free")
        third = guest(dashboard)
        third.close()
        second.close()
    finally:
        keeper.limits = default


def test_a_guest_connecting_again_and_again_gets_503(dashboard):
    keeper = dashboard._gatekeeper
    default, connects = keeper.limits, keeper._guest_connects
    keeper._guest_connects = TokenBucket(0.01, 3)
    try:
        for _ in range(3):
            guest(dashboard).close()
        with pytest.raises(InvalidStatus, match="503"):
            guest(dashboard).close()
        assert "guests connect too often" in dashboard.refusals.recent[-1].reason
        with operator(dashboard):  # operators are not counted
            pass
    finally:
        keeper.limits, keeper._guest_connects = default, connects


def test_the_links_token_sets_the_cookie_and_is_redirected_away(dashboard):
    port = dashboard.port
    conn = http.client.HTTPConnection("127.0.0.1", port, timeout=5)
    conn.request("GET", f"/?token={TOKEN.value}", headers={"Host": f"127.0.0.1:{port}"})
    response = conn.getresponse()
    response.read()
    assert response.status == 303 and response.getheader("Location") == "/"
    assert response.getheader("Referrer-Policy") == "no-referrer"
    set_cookie = response.getheader("Set-Cookie")
    assert set_cookie.startswith(f"wiithrow-operator-{port}=") and "Max-Age=43200" in set_cookie
    cookie = set_cookie.split(";")[0]
    conn.request("GET", "/", headers={"Host": f"127.0.0.1:{port}", "Cookie": cookie})
    page = conn.getresponse()
    assert page.status == 200 and b"<html" in page.read().lower() and page.getheader("Set-Cookie") is None
    conn.close()
    before = set(dashboard.clients.roles)
    origin = f"http://127.0.0.1:{port}"
    with connect(
        f"ws://127.0.0.1:{port}", subprotocols=[PROTOCOL], origin=origin, additional_headers={"Cookie": cookie}
    ) as c:
        c.send(viser_client.camera_message())
        new = wait_for(lambda: set(dashboard.clients.roles) - before, 10.0, "the client")
        assert dashboard.clients.roles[new.pop()] is Role.OPERATOR
    with pytest.raises(InvalidStatus, match="403"):  # the cookie without the page's Origin: nothing
        connect(f"ws://127.0.0.1:{port}", subprotocols=[PROTOCOL], additional_headers={"Cookie": cookie}).close()


class _BufferedConnection:
    """What the gate wraps: `recv` hands out what the connection still holds (refused messages,
    then one a guest may send), in `state`."""

    def __init__(self, messages: list[bytes], state) -> None:
        self._messages = list(messages)
        self.state = state

    async def recv(self, *args, **kwargs):
        return self._messages.pop(0)


@pytest.mark.parametrize("closed", [False, True])
def test_a_closed_connections_backlog_is_read_at_once_an_open_ones_at_the_rate(closed):
    """A guest over its refused rate is read late while it is connected; what a connection that is
    already closed left buffered (it can flood no more) is read at once, so that a flood ends with
    its connection and the dashboard's close never waits for it (it took 6 s after a bench's flood)."""
    import asyncio

    from websockets.protocol import State

    from tests.web.test_access import TOKEN
    from wiithrow.web import handshake
    from wiithrow.web.access import AccessPolicy, RefusalLog

    # 4 refused messages a second: a message is read late unless its reading took 250 ms (at the
    # default 20/s, 50 ms of a loaded host's scheduling earned the next one its token)
    limits = Limits(refused_burst=2, refused_per_s=4.0)
    keeper = handshake.Gatekeeper(AccessPolicy(TOKEN, "127.0.0.1"), RefusalLog(), limits)
    nested_message = nested(50)  # refused for a guest: an unknown message kind
    assert admit_message(Role.GUEST, nested_message, None) is not None
    camera = viser_client.camera_message()
    assert admit_message(Role.GUEST, camera, None) is None
    connection = _BufferedConnection([nested_message] * 6 + [camera], State.CLOSED if closed else State.OPEN)
    keeper._gate_messages(connection, Role.GUEST, "127.0.0.1:1")  # type: ignore[arg-type]
    assert asyncio.run(connection.recv()) == camera
    # the burst of 2 is free; open: the 4 others each waited for the bucket
    assert keeper.throttled == (0 if closed else 4)
