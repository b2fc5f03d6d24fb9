"""Who the dashboard lets in and what each may do, without a browser: the rules of
`wiithrow.web.access` as pure functions, then a dashboard on the simulated system (simulated
clock) spoken to through raw sockets and websockets: foreign Origin or Host get 403 and nothing
reaches viser; a native client needs the token; a guest's messages are dropped except Stop; every
click is checked again in the server; and the facts of viser 1.1 that `wiithrow.web.handshake`
wraps, so that an upgrade of viser that moves them fails here, loudly.
"""

from __future__ import annotations

import base64
import logging
import os
import re
import socket
import time
import tomllib
from pathlib import Path
from types import SimpleNamespace

import pytest
import viser
import viser._messages as vm
from websockets.sync.client import connect

from tests.conftest import wait_for
from wiithrow.app.cli.bench import viser_client
from wiithrow.app.errors import AppError
from wiithrow.web import handshake
from wiithrow.web.access import (
    AccessPolicy,
    RefusalLog,
    Role,
    Token,
    admit_message,
    check_token,
    new_token,
    refuse_exposure_without_token,
    resolve_token,
)
from wiithrow.web.controls import GUEST_REASON

TOKEN = Token("0123456789abcdef-test-token", "--token")
PROTOCOL = f"viser-v{viser.__version__}"


def policy(bound: str = "127.0.0.1", allow: tuple[str, ...] = ()) -> AccessPolicy:
    return AccessPolicy(TOKEN, bound, allow)


def ws(headers: dict[str, str], path: str = "/", p: AccessPolicy | None = None):
    return (p or policy()).check_request(headers, path, websocket=True, port=8080)


# -- the rules ------------------------------------------------------------------------------------------


def test_host_must_be_a_name_the_server_answers_to():
    p = policy()
    for host in ("127.0.0.1:8080", "localhost:8080", "[::1]:8080", "127.0.0.2:9999", "LOCALHOST:8080"):
        assert p.check_request({"Host": host}, "/", websocket=False, port=8080).role is Role.GUEST, host
    for host in ("evil.example.com:8080", "evil.example.com", "10.0.0.5:8080", "localhost.evil.com:8080", "a@b", ""):
        verdict = p.check_request({"Host": host}, "/", websocket=False, port=8080)
        assert verdict.role is None and "Host" in verdict.reason, host
    assert p.check_request({}, "/", websocket=False, port=8080).role is None
    lab = policy("0.0.0.0", ("robot-lab.local",))
    for host in ("robot-lab.local:8080", "192.168.1.20:8080", "[fe80::1]:8080"):  # names given, any IP literal
        assert lab.check_request({"Host": host}, "/", websocket=False, port=8080).role is Role.GUEST, host
    assert lab.check_request({"Host": "rebind.evil.com:8080"}, "/", websocket=False, port=8080).role is None
    bound = policy("192.168.1.20")
    assert bound.check_request({"Host": "192.168.1.20:8080"}, "/", websocket=False, port=8080).role is Role.GUEST
    assert bound.check_request({"Host": "192.168.1.21:8080"}, "/", websocket=False, port=8080).role is None


def test_origin_must_be_the_dashboards_own():
    own = {"Host": "127.0.0.1:8080", "Origin": "http://127.0.0.1:8080"}
    assert ws(own).role is Role.GUEST
    for origin in (
        "http://127.0.0.1:9999",  # another port of this machine
        "http://localhost:8080",  # another name: another origin
        "https://127.0.0.1:8080",
        "http://evil.example.com",
        "null",
        "",
    ):
        verdict = ws({"Host": "127.0.0.1:8080", "Origin": origin})
        assert verdict.role is None and "Origin" in verdict.reason, origin
    assert ws({"Host": "localhost", "Origin": "http://localhost"}).role is Role.GUEST  # port 80 both ways
    # a page's other requests (not websocket) are refused too when they say they come from elsewhere
    other = {"Host": "127.0.0.1:8080", "Origin": "http://127.0.0.1:9999"}
    assert policy().check_request(other, "/", websocket=False, port=8080).role is None


def test_the_token_makes_an_operator_and_a_native_client_needs_it():
    host = {"Host": "127.0.0.1:8080"}
    assert ws(host).role is None, "a websocket without Origin and token is refused"
    assert ws(host, f"/?token={TOKEN.value}").role is Role.OPERATOR
    assert ws({**host, "Authorization": f"Bearer {TOKEN.value}"}).role is Role.OPERATOR
    wrong = ws(host, "/?token=0123456789abcdef-test-tokeX")
    assert wrong.role is None and wrong.wrong_token
    browser = {**host, "Origin": "http://127.0.0.1:8080"}
    assert ws(browser, "/?token=nope").role is Role.GUEST and ws(browser, "/?token=nope").wrong_token
    assert not policy().check_request(host, "/", websocket=False, port=8080).set_cookie


def test_the_operator_cookie_is_random_per_start_expires_and_is_bound_to_the_pages_origin_and_port():
    now = [1_000_000.0]
    p = AccessPolicy(TOKEN, "127.0.0.1", clock=lambda: now[0])
    host = {"Host": "127.0.0.1:8080"}
    browser = {**host, "Origin": "http://127.0.0.1:8080"}
    # the link's page load: the cookie, and a redirect to the address without the token
    page = p.check_request(host, f"/?view=top&token={TOKEN.value}", websocket=False, port=8080)
    assert page.role is Role.OPERATOR and page.set_cookie and page.redirect == "/?view=top"
    assert p.check_request(host, f"/?token={TOKEN.value}", websocket=False, port=8080).redirect == "/"
    header = p.operator_cookie(8080)
    assert "HttpOnly" in header and "SameSite=Strict" in header and "Max-Age=43200" in header
    assert TOKEN.value not in header
    cookie = header.split(";")[0]
    assert cookie != p.operator_cookie(8080).split(";")[0], "a new nonce each time"
    assert ws({**browser, "Cookie": f"theme=dark; {cookie}"}, p=p).role is Role.OPERATOR
    assert p.check_request({**host, "Cookie": cookie}, "/", websocket=False, port=8080).role is Role.OPERATOR
    # a websocket without the page's Origin (a native client) gets nothing from the cookie
    refused = ws({**host, "Cookie": cookie}, p=p)
    assert refused.role is None and "needs the operator token" in refused.reason
    # bound to the port: renamed for another port it is not valid there
    other = {"Host": "127.0.0.1:8081", "Origin": "http://127.0.0.1:8081", "Cookie": cookie.replace("8080", "8081", 1)}
    assert p.check_request(other, "/", websocket=True, port=8081).role is Role.GUEST
    for forged in (cookie[:-1] + ("0" if cookie[-1] != "0" else "1"), cookie.split("=")[0] + "=x.y.z", "junk"):
        assert ws({**browser, "Cookie": forged}, p=p).role is Role.GUEST, forged
    # random per start: the same token, another start, does not accept it
    assert ws({**browser, "Cookie": cookie}, p=AccessPolicy(TOKEN, "127.0.0.1")).role is Role.GUEST
    # it expires (the browser is told Max-Age; the server checks it too)
    now[0] += 12 * 3600 - 5
    assert ws({**browser, "Cookie": cookie}, p=p).role is Role.OPERATOR
    now[0] += 10
    assert ws({**browser, "Cookie": cookie}, p=p).role is Role.GUEST
    short = AccessPolicy(TOKEN, "127.0.0.1", cookie_max_age_s=60.0)
    assert "Max-Age=60;" in short.operator_cookie(8080)


def test_messages_a_role_may_send():
    stop = "stop-uuid"
    camera = viser_client.camera_message()
    click = viser_client.click("calibrate-uuid")
    assert admit_message(Role.OPERATOR, click, stop) is None
    assert admit_message(Role.OPERATOR, camera, stop) is None
    assert admit_message(Role.GUEST, camera, stop) is None
    assert admit_message(Role.GUEST, viser_client.click(stop), stop) is None, "Stop is everyone's"
    assert "Stop only" in admit_message(Role.GUEST, click, stop)
    drag = viser_client.encode(
        {
            "type": "TransformControlsUpdateMessage",
            "name": "/target_handle",
            "wxyz": [1, 0, 0, 0],
            "position": [1, 0, 0],
        }
    )
    assert "a guest may watch" in admit_message(Role.GUEST, drag, stop)
    assert admit_message(Role.OPERATOR, drag, stop) is None
    hide = viser_client.encode({"type": "GuiUpdateMessage", "uuid": stop, "updates": {"visible": False}})
    for role in Role:
        assert "more than a value" in admit_message(role, hide, stop)
        assert "share tunnels" in admit_message(role, viser_client.encode({"type": "ShareUrlRequest"}), stop)
        for junk in (b"\xc1", b"\x93\x01\x02\x03", "text", viser_client.encode({"uuid": "x"})):
            assert admit_message(role, junk, stop), junk


def test_the_token_given_or_made(tmp_path):
    assert resolve_token(None, None, {}).source == "generated"
    a, b = new_token(), new_token()
    assert a.value != b.value and len(a.value) >= 43 and a.value not in repr(a)
    assert resolve_token("abcdefghijklmnop", None, {}).source == "--token"
    f = tmp_path / "token"
    f.write_text("  from-a-file-0123456789\n")
    t = resolve_token(None, str(f), {"WIITHROW_TOKEN": "from-the-environment"})
    assert t.value == "from-a-file-0123456789" and t.given and not t.printable
    env = resolve_token(None, None, {"WIITHROW_TOKEN": "from-the-environment"})
    assert env.value == "from-the-environment" and not env.printable
    errors = [
        (("abcdefghijklmnop", str(f)), "not both"),
        ((None, str(tmp_path / "missing")), "cannot read"),
        ((None, str(tmp_path)), "cannot read"),
        (("tiny-tok", None), "too short"),
        (("has spaces in it, sixteen+", None), "may hold only"),
    ]
    f2 = tmp_path / "empty"
    f2.write_text("\n")
    errors.append(((None, str(f2)), "empty"))
    for (value, file), why in errors:
        with pytest.raises(AppError, match=why) as raised:
            resolve_token(value, file, {})
        assert value is None or value not in str(raised.value), "an error never echoes the token"
    with pytest.raises(AppError, match="too short"):
        resolve_token(None, None, {"WIITHROW_TOKEN": "tiny"})
    assert check_token("a" * 16, "x").value == "a" * 16


def test_beyond_loopback_needs_a_chosen_token():
    refuse_exposure_without_token("127.0.0.1", new_token())
    refuse_exposure_without_token("0.0.0.0", TOKEN)
    with pytest.raises(AppError, match="--host 0.0.0.0"):
        refuse_exposure_without_token("0.0.0.0", new_token())


def test_refusals_are_logged_at_a_bounded_rate_and_kept_bounded(caplog):
    now = [0.0]
    log = RefusalLog(burst=5, period_s=10.0, keep=20, clock=lambda: now[0])
    with caplog.at_level(logging.WARNING, logger="wiithrow.web.access"):
        for _ in range(1000):
            log.record("request", "10.0.0.1:1", "Origin 'http://evil' is not this dashboard's")
        assert len(caplog.records) == 5
        now[0] = 11.0
        log.record("message", "10.0.0.1:1", "a guest may press Stop only")
    assert len(caplog.records) == 6 and "995 more not logged" in caplog.records[-1].getMessage()
    assert len(log.recent) == 20 and log.counts == {"request": 1000, "message": 1, "token": 0}


# -- a dashboard spoken to through sockets ------------------------------------------------------------------


@pytest.fixture(scope="module")
def dashboard():
    from wiithrow.app.session import demo_target_base, simulated_session
    from wiithrow.web.server import Dashboard

    session = simulated_session(seed=3, calibration=None, quiet=True)
    session.set_target(demo_target_base())
    dash = Dashboard(session, port=0, token=TOKEN, analysis_process=False, derived_figures=False)
    dash.refresh()
    # what reaches viser's own dispatch (after the gate), by message type
    dash.reached = reached = {}
    for kind in (vm.GuiUpdateMessage, vm.ViewerCameraMessage, vm.TransformControlsUpdateMessage, vm.ShareUrlRequest):
        dash.server._websock_server.register_handler(  # a private attribute, in a test only
            kind, lambda _client, message: reached.__setitem__(type(message), reached.get(type(message), 0) + 1)
        )
    yield dash
    dash.close()
    session.close()


def raw_upgrade(port: int, headers: dict[str, str], then: bytes = b"", path: str = "/") -> tuple[int, bytes]:
    """A websocket upgrade written by hand (every header as given), followed at once by `then`;
    the response's status and whatever else the server sent in 1 s."""
    key = base64.b64encode(os.urandom(16)).decode()
    lines = [f"GET {path} HTTP/1.1", "Upgrade: websocket", "Connection: Upgrade", f"Sec-WebSocket-Key: {key}"]
    lines += ["Sec-WebSocket-Version: 13", f"Sec-WebSocket-Protocol: {PROTOCOL}"]
    lines += [f"{name}: {value}" for name, value in headers.items()]
    with socket.create_connection(("127.0.0.1", port), timeout=5.0) as sock:
        sock.sendall(("\r\n".join(lines) + "\r\n\r\n").encode() + then)
        data = b""
        end = time.monotonic() + 1.0
        while time.monotonic() < end:
            try:
                chunk = sock.recv(65536)
            except (TimeoutError, ConnectionResetError):
                break
            if not chunk:
                break
            data += chunk
    status = int(data.split(b" ", 2)[1]) if data.startswith(b"HTTP/1.1 ") else 0
    return status, data


def frame(payload: bytes) -> bytes:
    """One masked binary websocket frame, as a client sends it."""
    mask = os.urandom(4)
    n = len(payload)
    head = bytes([0x82]) + (bytes([0x80 | n]) if n < 126 else bytes([0x80 | 126]) + n.to_bytes(2, "big"))
    return head + mask + bytes(b ^ mask[i % 4] for i, b in enumerate(payload))


@pytest.mark.parametrize(
    "headers, why",
    [
        ({"Origin": "http://evil.example.com"}, "Origin 'http://evil.example.com'"),
        ({"Origin": "http://127.0.0.1:{other}"}, "Origin 'http://127.0.0.1:{other}'"),
        ({"Host": "evil.example.com:{port}", "Origin": "http://evil.example.com:{port}"}, "Host 'evil.example.com"),
        ({}, "without Origin"),
    ],
    ids=["foreign-origin", "other-port", "foreign-host", "native-without-token"],
)
def test_a_foreign_websocket_gets_403_and_nothing_reaches_viser(dashboard, headers, why):
    port = dashboard.port
    values = {"port": port, "other": port + 1}
    headers = {"Host": f"127.0.0.1:{port}", **{k: v.format(**values) for k, v in headers.items()}}
    before = (dict(dashboard.reached), dashboard.stops, dashboard.refusals.counts["request"])
    forged = frame(viser_client.camera_message()) + frame(viser_client.click(dashboard._gatekeeper.stop_uuid))
    status, data = raw_upgrade(port, headers, then=forged)
    assert status == 403, data[:200]
    time.sleep(0.3)
    assert dashboard.reached == before[0], "no message of a refused connection reaches viser"
    assert dashboard.stops == before[1]
    assert dashboard.refusals.counts["request"] == before[2] + 1
    assert why.format(**values) in dashboard.refusals.recent[-1].reason


def test_a_foreign_host_gets_403_for_the_page_too(dashboard):
    import http.client

    for host, status in (("evil.example.com", 403), ("127.0.0.1", 200), ("localhost", 200)):
        conn = http.client.HTTPConnection("127.0.0.1", dashboard.port, timeout=5)
        conn.request("GET", "/", headers={"Host": f"{host}:{dashboard.port}"})
        response = conn.getresponse()
        body = response.read()
        assert response.status == status, host
        if status == 200:
            assert b"<html" in body.lower()
            assert response.getheader("X-Frame-Options") == "DENY", "no other site may frame the controls"
            assert response.getheader("Referrer-Policy") == "no-referrer", "the link's token never leaks as Referer"
        conn.close()


def the_client(dashboard, before: set[int]) -> int:
    """The id of the one client that connected since `before`."""
    new = wait_for(lambda: set(dashboard.clients.roles) - before, 10.0, "the client to connect")
    assert len(new) == 1
    return new.pop()


def test_the_token_opens_a_native_operator_connection(dashboard):
    url = f"ws://127.0.0.1:{dashboard.port}/?token={TOKEN.value}"
    before = set(dashboard.clients.roles)
    with connect(url, subprotocols=[PROTOCOL], max_size=None) as c:
        c.send(viser_client.camera_message())
        client_id = the_client(dashboard, before)
        assert dashboard.clients.roles[client_id] is Role.OPERATOR, "the handshake's role reaches viser's client"
        buttons = viser_client.Buttons()
        end = time.monotonic() + 5.0
        while not buttons.enabled("Calibrate") and time.monotonic() < end:
            buttons.read(c.recv(timeout=5.0))
        assert buttons.enabled("Calibrate") and "Track target" in buttons.uuid
    with pytest.raises(Exception, match="403"):
        connect(url.replace(TOKEN.value, TOKEN.value[:-1] + "X"), subprotocols=[PROTOCOL]).close()


def test_a_guest_watches_presses_stop_and_starts_nothing(dashboard, caplog):
    session = dashboard.session
    origin = f"http://127.0.0.1:{dashboard.port}"
    operator = connect(f"ws://127.0.0.1:{dashboard.port}/?token={TOKEN.value}", subprotocols=[PROTOCOL])
    before = set(dashboard.clients.roles)
    operator.send(viser_client.camera_message())
    operator_id = the_client(dashboard, before)
    before = set(dashboard.clients.roles)
    with operator, connect(f"ws://127.0.0.1:{dashboard.port}", subprotocols=[PROTOCOL], origin=origin) as guest:
        guest.send(viser_client.camera_message())
        guest_id = the_client(dashboard, before)
        assert dashboard.clients.roles[guest_id] is Role.GUEST
        mine = next(c for c in dashboard.clients.controls() if c.client.client_id == guest_id)
        for button in (mine.calibrate, mine.track, mine.preview, mine.throw, mine.home, mine.poses):
            assert button.disabled and GUEST_REASON in (button.hint or ""), button.label
        assert mine.handle is None, "a guest cannot drag the target"
        theirs = next(c for c in dashboard.clients.controls() if c.client.client_id == operator_id)
        reached, started, q = dict(dashboard.reached), dashboard.runner.started, session.world.arm.state().q.copy()
        refused = dashboard.refusals.counts["message"]
        forged = [
            viser_client.click(mine.track._impl.uuid),  # its own disabled button
            viser_client.click(theirs.track._impl.uuid),  # the operator's
            viser_client.click(theirs.calibrate._impl.uuid),
            viser_client.encode(
                {
                    "type": "TransformControlsUpdateMessage",
                    "name": "/target_handle",
                    "wxyz": [1, 0, 0, 0],
                    "position": [1, 0, 0],
                }
            ),
            viser_client.encode(
                {"type": "GuiUpdateMessage", "uuid": dashboard._gatekeeper.stop_uuid, "updates": {"visible": False}}
            ),
            viser_client.encode({"type": "ShareUrlRequest"}),
        ]
        with caplog.at_level(logging.WARNING, logger="wiithrow.web.access"):
            for message in forged:
                guest.send(message)
            wait_for(lambda: dashboard.refusals.counts["message"] >= refused + len(forged), 5.0, "the refusals")
        time.sleep(0.3)
        assert dashboard.reached == reached, "none of a guest's forged messages reaches viser"
        assert dashboard.runner.started == started and not session.busy
        assert (session.world.arm.state().q == q).all()
        assert any("guest" in r.getMessage() and "Stop only" in r.getMessage() for r in caplog.records)
        assert TOKEN.value not in caplog.text
        # Stop is everyone's
        stops = dashboard.stops
        guest.send(viser_client.click(dashboard._gatekeeper.stop_uuid))
        wait_for(lambda: dashboard.stops == stops + 1, 5.0, "the guest's Stop")
        # every click is checked again in the server: a guest's click that got past the gate starts nothing
        handle = dashboard.server.get_clients()[guest_id]
        dashboard._on_track(SimpleNamespace(client=handle))
        dashboard._on_calibrate(SimpleNamespace(client=handle), 8)
        dashboard._target_moved(session.world.source_positions_base()[1] + 0.1, handle)
        assert dashboard.runner.started == started and not session.busy
        assert "Track target from a guest client: refused" in dashboard.refusals.recent[-3].reason


# -- the facts of viser that handshake.py wraps -----------------------------------------------------------------


def test_the_viser_we_wrap_is_the_one_installed_and_pinned():
    assert handshake.viser_version() in handshake.SUPPORTED_VISER, (
        f"viser {viser.__version__}: check web/handshake.py against this viser, then add it to SUPPORTED_VISER"
    )
    pyproject = tomllib.loads((Path(__file__).parents[2] / "pyproject.toml").read_text())
    pins = [d for d in pyproject["project"]["dependencies"] if re.match(r"viser\b", d)]
    assert pins and pins[0].split("#")[0].strip() == "viser>=1.1,<1.2", pins


def test_a_viser_that_starts_differently_is_refused(monkeypatch):
    stopped = []

    class Unwrappable:  # starts its server without websockets.asyncio.server.serve's process_request
        def __init__(self, **kwargs):
            pass

        def stop(self):
            stopped.append(True)

    monkeypatch.setattr(handshake.viser, "ViserServer", Unwrappable)
    keeper = handshake.Gatekeeper(AccessPolicy(TOKEN, "127.0.0.1"), RefusalLog())
    with pytest.raises(handshake.UnsupportedViser, match="cannot be installed"):
        handshake.start_viser(keeper, host="127.0.0.1", port=0)
    assert stopped, "the unchecked server is stopped"
    monkeypatch.setattr(handshake.viser, "__version__", "1.2.0")
    with pytest.raises(handshake.UnsupportedViser, match="viser 1.2.0"):
        handshake.start_viser(keeper, host="127.0.0.1", port=0)


def test_the_serve_replacement_lasts_only_the_construction(dashboard):
    """(That the wrapped process_request and recv are what viser calls is seen working above: the
    403s, and a guest's dropped messages that never reach viser's dispatch.)"""
    import websockets.asyncio.server

    assert dashboard._gatekeeper.wrapped_calls >= 1
    assert websockets.asyncio.server.serve is websockets.asyncio.server.__dict__["serve"]
    assert websockets.asyncio.server.serve.__qualname__ == "serve", "websockets' own serve is back"
