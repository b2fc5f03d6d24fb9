"""The dashboard in a real browser (headless Chromium through Playwright): it loads and renders, its
panels are there, a throw needs a preview and a confirmation and makes exactly one throw, two
browsers racing make one throw, Stop halts a running throw, a browser closed mid-throw does not
stop it; and who gets in: a page from another origin (another local port, in the browser that
holds the operator's cookie) can neither open the websocket nor frame the page, a guest (the
address without the token) sees everything, can start nothing, and can Stop a throw.

Fixtures in conftest.py: one calibrated dashboard and two browser pages on it for the module.
Chromium renders WebGL in software here (SwiftShader): while the arm moves, a full-size scene
keeps a page's main thread so busy that one query of the page can take seconds (measured up to
19 s on two cores). So the pages are opened once, their 3D canvas is shrunk to a thumbnail
except where the scene itself is tested (it is still built and updated, only rasterised small),
each check is one round trip, and what happens during a throw is recorded in the page by a
MutationObserver and read afterwards. With WIITHROW_SCREENSHOT=PATH the throw test saves a
screenshot of the dashboard there (how docs/dashboard.png is made).
"""

from __future__ import annotations

import io
import json
import os
import re
import threading
import time
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer

import numpy as np
import pytest

from tests.conftest import PAGE_START_MS, SMALL_SCENE, small_scene_context, wait_for
from wiithrow.app.cli.bench import viser_client
from wiithrow.app.session import Event, Operation
from wiithrow.app.session.status import ERROR_PER_M
from wiithrow.web.access import Role
from wiithrow.web.controls import GUEST_REASON, label

pytestmark = pytest.mark.browser

HIDE_NOTIFICATIONS = ".mantine-Notification-root { display: none !important; }"
RECORD_BUTTONS = """() => {
  window.__buttons = [];
  const snap = () => {
    const m = {};
    document.querySelectorAll('button').forEach(b => { const t = b.textContent.trim(); if (t) m[t] = !b.disabled; });
    window.__buttons.push(m);
  };
  snap();
  new MutationObserver(snap).observe(document.body,
    {subtree: true, childList: true, attributes: true, attributeFilter: ['disabled', 'data-disabled']});
}"""


def reason_shown(text: str, name: str, why: str) -> bool:
    """The page says why button `name` is disabled: "name: why", or in a group of buttons held
    back by the same reason, said once ("Track target, Preview throw: why")."""
    return re.search(rf"{re.escape(name)}(?:, [^:·\n]+)?: {re.escape(why)}", text) is not None


class DashboardPage:
    """One browser's view of the dashboard, read and clicked in one round trip each."""

    def __init__(self, page) -> None:
        self.page = page
        self.events: list[str] = []  # what `follow_connection` saw: the page's console, its websocket's life

    def follow_connection(self) -> None:
        """Keep the page's console lines and its websockets' openings and closings in `events` (what
        a failing test says: viser's page drops a click while its socket is closed, saying so only
        in its console)."""
        self.page.on("console", lambda message: self.events.append(f"console: {message.text}"))

        def websocket(ws) -> None:
            self.events.append(f"websocket opened {ws.url}")
            ws.on("close", lambda _ws: self.events.append(f"websocket closed {ws.url}"))

        self.page.on("websocket", websocket)

    def record_buttons(self) -> None:
        """Start recording every change of the buttons' enabled states (read with `recorded`)."""
        self.page.evaluate(RECORD_BUTTONS)

    def recorded(self) -> list[dict[str, bool]]:
        return self.page.evaluate("() => window.__buttons")

    def buttons(self) -> dict[str, bool]:
        """Button label -> enabled."""
        pairs = self.page.evaluate(
            "() => [...document.querySelectorAll('button')].map(b => [b.textContent.trim(), !b.disabled])"
        )
        return {name: enabled for name, enabled in pairs if name}

    def text(self) -> str:
        return self.page.evaluate("() => document.body.innerText")

    def click(self, name: str, timeout_s: float = 20.0) -> None:
        """Click the button labelled `name` once it is enabled (a DOM click event: Playwright's own
        click waits for animation frames, seconds each with software WebGL)."""
        script = (
            "name => { const b = [...document.querySelectorAll('button')].find(e => e.textContent.trim() == name);"
            " if (!b) return 'missing'; if (b.disabled) return 'disabled'; b.click(); return 'clicked'; }"
        )
        wait_for(lambda: self.page.evaluate(script, name) == "clicked", timeout_s, f"button {name!r} to click")

    def click_at(self, name: str, timeout_s: float = 20.0) -> float:
        """`click`, returning the page's wall clock when it clicked (`Date.now()`, s)."""
        script = (
            "name => { const b = [...document.querySelectorAll('button')].find(e => e.textContent.trim() == name);"
            " if (!b || b.disabled) return null; const t = Date.now(); b.click(); return t; }"
        )
        at = wait_for(lambda: self.page.evaluate(script, name), timeout_s, f"button {name!r} to click")
        return float(at) / 1000.0

    def wait_text(self, pattern: str, timeout_s: float = 10.0) -> str:
        regex = re.compile(pattern)
        return wait_for(lambda: regex.search(self.text()), timeout_s, f"{pattern!r} on the page").group(0)

    def wait_button(self, name: str, enabled: bool, timeout_s: float = 10.0) -> None:
        wait_for(
            lambda: self.buttons().get(name) is enabled,
            timeout_s,
            f"button {name!r} to be {'enabled' if enabled else 'disabled'}",
        )

    def screenshot(self) -> np.ndarray:
        import imageio.v3 as iio

        return iio.imread(io.BytesIO(self.page.screenshot()), extension=".png")[..., :3].astype(float)


@pytest.fixture()
def browsers(browser_pages) -> list[DashboardPage]:
    """The two browsers on the dashboard (no modal open, notifications cleared)."""
    pages = [DashboardPage(page) for page in browser_pages]
    for page in pages:
        page.page.evaluate(
            "() => document.querySelectorAll('.mantine-Notification-closeButton').forEach(b => b.click())"
        )
        page.page.evaluate(
            "css => { if (!document.getElementById('small-scene')) {"
            " const e = document.createElement('style'); e.id = 'small-scene'; e.textContent = css;"
            " document.head.appendChild(e); } }",
            SMALL_SCENE,
        )
    return pages


def full_scene(page: DashboardPage, full: bool = True) -> None:
    page.page.evaluate("full => { const e = document.getElementById('small-scene'); if (e) e.disabled = full; }", full)


def settle(session) -> None:
    wait_for(lambda: not session.busy and not session.world.arm.is_moving(), 30.0, "the system to be idle")


#: Tries of Track target in `track_and_preview` (see there).
TRACK_TRIES = 5


def track_and_preview(page: DashboardPage, session) -> None:
    """Track target, then Preview throw, through the buttons; returns when Throw is enabled."""
    # With this browser's software rendering saturating a small machine, the real-time
    # simulation can starve the 100 Hz loop long enough for the alignment to lose the target
    # (no frame for its lost timeout) and stop with status "lost". The dashboard reports it and
    # the operator presses Track target again; so do the tests, up to `TRACK_TRIES` times (three
    # lost in a row at a load of 13 on two cores). (The other
    # symptom of a starved loop, a command that starts behind the arm, the commander now
    # rebuilds itself: tests/test_alignment.py.)
    for _ in range(TRACK_TRIES):
        settle(session)
        before = session.alignment
        page.wait_button("Track target", True, timeout_s=30.0)
        page.click("Track target")
        wait_for(lambda: session.busy or session.alignment is not before, 5.0, "the alignment to start")  # noqa: B023 (called at once)
        wait_for(lambda: not session.busy, 40.0, "the alignment")
        if session.alignment is not before and session.alignment.converged:
            break
    assert session.alignment is not None and session.alignment.converged, session.alignment
    # a page's queries take seconds while software WebGL renders on a loaded machine (a third page
    # in test_a_browser_closed_mid_throw...: Throw took over 10 s to show enabled in one CI run)
    page.wait_button("Preview throw", True, timeout_s=30.0)
    page.click("Preview throw")
    wait_for(lambda: not session.busy and session.preview is not None, 20.0, "the preview")
    page.wait_button("Throw", True, timeout_s=30.0)


def test_page_loads_with_its_panels(browsers):
    page = browsers[0]
    for name in ("Stop", "Calibrate", "Track target"):  # once the page drew the calibration's end
        page.wait_button(name, True)
    buttons = page.buttons()
    for name in ("Stop", "Calibrate", "Track target", "Preview throw", "Throw", "Home"):
        assert name in buttons, f"no {name} button ({sorted(buttons)})"
    assert not buttons["Throw"], "Throw needs a preview first"
    text = page.text()
    for title in ("Cameras", "Calibration", "Throw", "Last throws", "Mono vs stereo"):
        assert title in text
    # the calibration's figures (the page shows them at its next frame after the calibration ended):
    # per-camera RMS, leave-one-out error, worst points
    page.wait_text("Leave-one-out 3D error")
    assert "Worst points" in page.text()
    page.wait_text(r"cam0 \d+\.\d+ px, cam1 \d+\.\d+ px")
    # each camera's view says what it sees: both remotes see the target
    page.wait_text(r"cam0: 1 dot\b")
    page.wait_text(r"cam1: 1 dot\b")


def test_every_disabled_button_says_why_in_the_page(browsers, live_dashboard):
    """Not only on hover: each disabled operation button's reason (the session's `refusal`, the
    text the server answers its click with) is written in the page beside it."""
    session = live_dashboard.session
    settle(session)
    page = browsers[0]
    wait_for(
        lambda: live_dashboard.states and live_dashboard._revision == session.snapshot().revision, 10.0, "a refresh"
    )
    states = dict(live_dashboard.states)
    disabled = {label(op): why for op, why in states.items() if why}
    assert "Throw" in disabled or session.preview is not None, states
    assert disabled, f"nothing is disabled now ({states}): this test needs a state that refuses something"
    for op, why in states.items():
        assert why == (session.refusal(op) or ""), "the buttons show what the session refuses"
    wait_for(
        lambda: all(reason_shown(page.text(), name, why) for name, why in disabled.items()),
        20.0,
        f"every disabled button's reason in the page ({disabled})",
    )
    buttons = page.buttons()
    for name in disabled:
        assert buttons.get(name) is False, f"{name} says why it is disabled but is not ({buttons})"


def scene_statistics(image: np.ndarray) -> tuple[float, float]:
    """Pixel variance and share of coloured pixels of the scene (left of the control panel)."""
    scene = image[:, : int(0.65 * image.shape[1])]
    colourful = (scene.max(axis=2) - scene.min(axis=2)) > 60  # the arm's blue, the cameras' green, the target
    return float(scene.mean(axis=2).var()), float(colourful.mean())


def test_scene_renders(browsers):
    page = browsers[0]
    page.page.add_style_tag(content=HIDE_NOTIFICATIONS)
    full_scene(page)
    # the viewer fades the scene in after loading; software rendering makes that take a while
    variance, coloured = 0.0, 0.0
    end = time.monotonic() + 40.0
    while time.monotonic() < end:
        variance, coloured = scene_statistics(page.screenshot())
        if variance > 150.0 and coloured > 0.001:
            break
        time.sleep(1.0)
    full_scene(page, False)
    assert variance > 150.0, f"the scene looks blank (pixel variance {variance:.1f})"
    assert coloured > 0.001, f"only {100 * coloured:.3f} % coloured pixels: is the arm drawn?"


def test_preview_then_throw_with_confirmation(browsers, live_dashboard):
    session = live_dashboard.session
    page = browsers[0]
    track_and_preview(page, session)
    before = len(session.history)
    page.click("Throw")
    page.wait_text(r"Throw \(preview \d+\): throw it\?")
    time.sleep(0.5)
    assert len(session.history) == before and not session.busy, "the throw must wait for the confirmation"
    page.click("Throw now")
    try:
        wait_for(lambda: len(session.history) > before and not session.busy, 30.0, "the throw")
    except pytest.fail.Exception:  # say what the session was doing (one CI run timed out here)
        pytest.fail(
            f"no throw recorded in 30 s: operation {session.operation!r}, last message {session.last_message!r}"
        )
    time.sleep(0.5)
    assert len(session.history) == before + 1
    record = session.history[-1]
    page.wait_text(rf"\b{record.index}\s+\d\d:\d\d:\d\d\s+{record.target_xz[0]:.3f}, {record.target_xz[1]:.3f}")
    if np.isfinite(record.error_m):
        page.wait_text(rf"\b{ERROR_PER_M * record.error_m:.1f}\b")
    shot = os.environ.get("WIITHROW_SCREENSHOT")
    if shot:
        page.page.add_style_tag(content=HIDE_NOTIFICATIONS)
        full_scene(page)
        time.sleep(3.0)
        page.page.screenshot(path=shot)
        full_scene(page, False)


def test_two_browsers_clicking_throw_make_one_throw(browsers, live_dashboard):
    session = live_dashboard.session
    a, b = browsers
    track_and_preview(a, session)
    b.wait_button("Throw", True)
    a.click("Throw")
    b.click("Throw")
    a.wait_text(r"Throw \(preview \d+\): throw it\?")
    b.wait_text(r"Throw \(preview \d+\): throw it\?")
    before, refused = len(session.history), live_dashboard.runner.refused
    b.record_buttons()
    a.click("Throw now")  # both confirmations, as close together as two browsers allow
    b.click("Throw now")
    wait_for(lambda: len(session.history) > before and not session.busy, 30.0, "the throw")
    time.sleep(1.0)
    assert len(session.history) == before + 1, "two confirmations must make exactly one throw"
    # while the throw ran, the other browser had every button that would start an operation
    # disabled, and Stop enabled
    states = b.recorded()
    assert any(
        not s.get("Calibrate", True)
        and not s.get("Track target", True)
        and not s.get("Preview throw", True)
        and not s.get("Throw", True)
        and s.get("Stop")
        for s in states
    ), states[-3:]
    # the browser that lost the race was told so
    told = "Busy|no longer current|did not complete"
    if live_dashboard.runner.refused > refused:
        b.wait_text(told)
    else:  # the second click reached the session, which refused it
        wait_for(lambda: re.search(told, a.text() + b.text()), 5.0, "a refusal notification")


#: Tries of `stop_a_throw`: a Stop that reaches the server after the release (a page's click takes
#: seconds on a loaded machine with software WebGL) tests nothing about the wind-up, so it is tried again.
STOP_TRIES = 3


#: The longest a Stop pressed in a page during a throw may take to reach the server's Stop handler (s):
#: well within the wind-up (about 1.5 s), so that Stop lands before the release.
STOP_LANDS_S = 0.5


def stop_a_throw(
    operator: DashboardPage, stopper: DashboardPage, dashboard, by: str = "the operator"
) -> tuple[int, list[float]]:
    """`operator` starts a throw from home (it winds up for about 1.5 s before the release),
    `stopper` presses Stop before the release: the throw ends, the arm rests, the stopped throw is
    recorded as failed in the wind-up, stopped by `by`. Whether Stop came before the release is the
    session's own record of the phase it stopped in (not the test's clock, which sees the start and
    the end late on a loaded machine); a Stop that came after it is tried again, up to `STOP_TRIES`
    times. Returns how many Stops it pressed, and each press's time from the click in the page
    (its `Date.now()`) to the server's Stop handler (`Dashboard.stop_seen_at`), one host's wall clock."""
    session = dashboard.session
    outcomes = []
    latencies: list[float] = []
    for tries in range(1, STOP_TRIES + 1):
        settle(session)
        homed = threading.Event()  # the session says when the arm is home (at once if it was there already)

        def on_event(event: Event) -> None:
            if event is Event.HOME:
                homed.set()  # noqa: B023 (the handler is unsubscribed within the iteration)

        session.subscribe(on_event)
        try:
            operator.click("Home")
            wait_for(homed.is_set, 30.0, "the arm to go home")
        finally:
            session.unsubscribe(on_event)
        settle(session)
        track_and_preview(operator, session)
        before = len(session.history)
        operator.click("Throw")
        operator.wait_text(r"Throw \(preview \d+\): throw it\?")
        # the dialog's overlay lets clicks through: a Stop at once after Throw now is never lost on it
        overlay = (
            "() => [...document.querySelectorAll('.mantine-Modal-overlay')].map(e => getComputedStyle(e).pointerEvents)"
        )
        assert set(operator.page.evaluate(overlay)) == {"none"}
        operator.click("Throw now")
        wait_for(lambda: session.operation is Operation.THROW, 15.0, "the throw to start")
        # the wind-up: the arm moves (it rested while the hand closed on the ball; a Stop then, which
        # a quick page on a loaded host sent three times in a row, ends the throw before its wind-up)
        wait_for(session.world.arm.is_moving, 15.0, "the wind-up to start")
        stops = dashboard.stops
        clicked_at = stopper.click_at("Stop")
        wait_for(lambda: dashboard.stops > stops, 30.0, "the Stop to reach the server")  # noqa: B023 (called at once)
        latencies.append(dashboard.stop_seen_at - clicked_at)
        wait_for(lambda: not session.busy, 30.0, "the throw to end")
        wait_for(lambda: not session.world.arm.is_moving(), 5.0, "the arm to come to rest")
        # a throw, stopped or not, is kept (issue 20: never dropped)
        assert len(session.history) == before + 1, "a throw is recorded, stopped or not"
        stopped = session.history[-1]
        outcomes.append(stopped.failure or f"thrown: landed at {stopped.landing_xz}")
        if stopped.failure is None or "failed in the wind-up" not in stopped.failure:
            continue  # Stop reached the server after the release: this try tested nothing
        assert np.all(np.abs(session.world.arm.state().dq) < 1e-6)
        # a stopped throw is kept as failed, with the reason the operator sees
        assert f"stopped by {by}" in stopped.failure, stopped.failure
        assert "the hand kept the ball" in stopped.failure and np.isnan(stopped.landing_xz).all()
        return tries, latencies
    pytest.fail(f"Stop never ended a throw in its wind-up in {STOP_TRIES} tries: {outcomes}")


def test_stop_halts_a_running_throw(browsers, live_dashboard):
    """Stop pressed in a page during a throw lands at once (software WebGL, the scene plain as it
    lightens itself on such a browser): the server's handler runs within `STOP_LANDS_S` of the click."""
    _, latencies = stop_a_throw(browsers[1], browsers[1], live_dashboard)
    print(f"\nStop, click in the page to the server's handler: {', '.join(f'{1e3 * t:.0f} ms' for t in latencies)}")
    assert max(latencies) < STOP_LANDS_S, latencies
    browsers[1].wait_text("Throw did not complete")


# -- who gets in ---------------------------------------------------------------------------------------------

OTHER_ORIGIN_PAGE = """<!doctype html><html><body>
<script>
const bytes = a => new Uint8Array(a);
window.attempt = new Promise(resolve => {
  const ws = new WebSocket(%(ws)s, [%(protocol)s]);
  ws.binaryType = "arraybuffer";
  ws.onopen = () => { ws.send(bytes(%(camera)s)); window.socket = ws; resolve("open"); };
  ws.onerror = () => resolve("refused");
  ws.onclose = () => resolve("refused");
});
</script>
<iframe id="dashboard" src=%(page)s width="800" height="600"></iframe>
</body></html>"""


class OtherOrigin:
    """A second local HTTP server, on another port: another origin, the same site as 127.0.0.1."""

    def __init__(self, html: str) -> None:
        body = html.encode()

        class Handler(BaseHTTPRequestHandler):
            def do_GET(self) -> None:
                self.send_response(200)
                self.send_header("Content-Type", "text/html; charset=utf-8")
                self.send_header("Content-Length", str(len(body)))
                self.end_headers()
                self.wfile.write(body)

            def log_message(self, *args) -> None:
                pass

        self.server = ThreadingHTTPServer(("127.0.0.1", 0), Handler)
        self.url = f"http://127.0.0.1:{self.server.server_address[1]}/"
        threading.Thread(target=self.server.serve_forever, daemon=True).start()

    def close(self) -> None:
        self.server.shutdown()
        self.server.server_close()


#: How far (rad) the measured joints wander while the arm rests: their noise is about 2 mrad; any
#: operation turns a joint by far more (Track target: joint 1 by the target's azimuth).
AT_REST_RAD = 0.01


def moved_since(session, q0: np.ndarray) -> float:
    """The largest change of a measured joint since `q0` (rad)."""
    return float(np.max(np.abs(session.world.arm.state().q - q0)))


def test_a_page_from_another_origin_cannot_open_the_websocket_or_frame_the_page(browsers, live_dashboard):
    session = live_dashboard.session
    settle(session)
    operator = browsers[0].page
    cookie = f"wiithrow-operator-{live_dashboard.port}"
    assert any(c["name"] == cookie for c in operator.context.cookies()), "the operator's browser holds the cookie"
    other = OtherOrigin(
        OTHER_ORIGIN_PAGE
        % {
            "ws": json.dumps(live_dashboard.url.replace("http", "ws", 1)),
            "protocol": json.dumps(viser_client.PROTOCOL),
            "camera": json.dumps(list(viser_client.camera_message())),
            "page": json.dumps(live_dashboard.url),
        }
    )
    clients = len(live_dashboard.server.get_clients())
    q0, started = session.world.arm.state().q.copy(), live_dashboard.runner.started
    refused = live_dashboard.refusals.counts["request"]
    page = operator.context.new_page()  # the operator's own browser, on another site's page
    try:
        page.goto(other.url)
        assert page.evaluate("() => window.attempt") == "refused"
        frame = wait_for(lambda: next((f for f in page.frames[1:] if f.url != "about:blank"), None), 20.0, "the frame")
        assert frame.url.startswith("chrome-error://"), f"the dashboard let itself be framed: {frame.url}"
        assert len(live_dashboard.server.get_clients()) == clients
    finally:
        page.close()
        other.close()
    assert moved_since(session, q0) < AT_REST_RAD and live_dashboard.runner.started == started and not session.busy
    assert live_dashboard.refusals.counts["request"] >= refused + 1
    reasons = [r.reason for r in live_dashboard.refusals.recent if r.kind == "request"]
    assert any(f"Origin '{other.url[:-1]}' is not this dashboard's" in r for r in reasons), reasons[-3:]


@pytest.fixture(scope="module")
def guest(chromium, browser_pages, live_dashboard):
    """A browser on the dashboard's address without the token (its own context: no cookie)."""
    context = small_scene_context(chromium)
    page = DashboardPage(context.new_page())
    before = set(live_dashboard.clients.roles)
    page.page.goto(live_dashboard.url)
    page.page.get_by_role("button", name="Stop", exact=True).wait_for(timeout=PAGE_START_MS)
    page.client_id = wait_for(lambda: set(live_dashboard.clients.roles) - before, 30.0, "the guest to connect").pop()
    yield page
    context.close()


def test_a_guest_sees_everything_and_can_start_nothing(guest, browsers, live_dashboard):
    session = live_dashboard.session
    settle(session)
    assert live_dashboard.clients.roles[guest.client_id] is Role.GUEST
    # the page draws its own controls once their messages came (a CI run read them before: Stop only)
    names = ("Calibrate", "Track target", "Preview throw", "Throw", "Home")
    wait_for(lambda: all(name in guest.buttons() for name in names), 30.0, "the guest's controls on the page")
    buttons = guest.buttons()
    for name in names:
        assert buttons.get(name) is False, f"{name} must be disabled for a guest ({buttons})"
    assert buttons["Stop"]
    # the page says they are a guest and how to become an operator, and why each control is disabled
    guest.wait_text("You are a guest")
    guest.wait_text(re.escape("open the operator's link"))
    assert guest.text().count(GUEST_REASON) >= 2, "each folder's line says why its controls are disabled"
    mine = next(c for c in live_dashboard.clients.controls() if c.client.client_id == guest.client_id)
    assert all("view only" in (b.hint or "") for b in (mine.calibrate, mine.track, mine.throw))
    # what the operators see, live: the calibration's figures, each camera's dots, the same status
    guest.wait_text("Leave-one-out 3D error")
    guest.wait_text(r"cam0: 1 dot\b")
    status = live_dashboard.panels.status.content.split("\n")[0].replace("**", "")
    guest.wait_text(re.escape(status))
    # a guest's connection forging the clicks of a Track button (its own, disabled, and an operator's)
    theirs = next(c for c in live_dashboard.clients.controls() if c.role is Role.OPERATOR)
    clicks = [list(viser_client.click(c.track._impl.uuid)) for c in (mine, theirs)]
    q0, started = session.world.arm.state().q.copy(), live_dashboard.runner.started
    ignored = live_dashboard.refusals.counts["message"]
    sent = guest.page.evaluate(
        """([url, protocol, camera, clicks]) => new Promise(resolve => {
             const ws = new WebSocket(url, [protocol]);
             ws.onopen = () => { ws.send(new Uint8Array(camera));
                                 clicks.forEach(c => ws.send(new Uint8Array(c)));
                                 setTimeout(() => { ws.close(); resolve("sent"); }, 500); };
             ws.onerror = () => resolve("refused");
           })""",
        [
            live_dashboard.url.replace("http", "ws", 1),
            viser_client.PROTOCOL,
            list(viser_client.camera_message()),
            clicks,
        ],
    )
    assert sent == "sent", "a guest's connection is let in (to watch)"
    wait_for(lambda: live_dashboard.refusals.counts["message"] >= ignored + 2, 10.0, "the forged clicks to be refused")
    time.sleep(1.0)
    assert live_dashboard.runner.started == started and not session.busy, "a forged click started something"
    assert moved_since(session, q0) < AT_REST_RAD


def test_stop_from_a_guest_stops_a_running_throw(guest, browsers, live_dashboard):
    stops = live_dashboard.stops
    pressed, latencies = stop_a_throw(browsers[1], guest, live_dashboard, by="a guest")
    print(f"\nA guest's Stop, click to the server's handler: {', '.join(f'{1e3 * t:.0f} ms' for t in latencies)}")
    assert live_dashboard.stops == stops + pressed
    assert max(latencies) < STOP_LANDS_S, latencies


# -- last in the module: it closes one of the module's two operator pages -------------------------------


def test_a_browser_closed_mid_throw_lets_the_throw_finish(browsers, live_dashboard):
    """The throw belongs to the server, not to the browser that confirmed it. The browser is one
    of the module's pages (a page of its own would cost another software-WebGL start, tens of
    seconds on a loaded machine), so this test comes last in the module: after it that page is gone."""
    session = live_dashboard.session
    page = browsers[0]
    track_and_preview(page, session)
    before = len(session.history)
    clients = len(live_dashboard.server.get_clients())
    page.click("Throw")
    page.wait_text(r"Throw \(preview \d+\): throw it\?")
    page.click("Throw now")
    wait_for(lambda: session.operation is Operation.THROW, 15.0, "the throw to start")
    page.page.context.close()  # the operator's browser goes away mid-throw
    wait_for(lambda: not session.busy, 30.0, "the throw to finish")
    assert len(session.history) == before + 1, "the throw finished and was recorded"
    wait_for(lambda: not session.world.arm.is_moving(), 5.0, "the arm to come to rest")
    wait_for(lambda: len(live_dashboard.server.get_clients()) == clients - 1, 10.0, "the client to leave")
