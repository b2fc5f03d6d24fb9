"""The dashboard in a real browser (headless Chromium through Playwright): it loads and renders, its
panels are there, a throw needs a preview and a confirmation and makes exactly one throw, two
browsers racing make one throw, Stop halts a running throw, a browser closed mid-throw does not
stop it.

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
import os
import re
import time

import numpy as np
import pytest

from tests.conftest import wait_for

pytestmark = pytest.mark.browser

HIDE_NOTIFICATIONS = ".mantine-Notification-root { display: none !important; }"
SMALL_SCENE = "canvas { width: 160px !important; height: 120px !important; }"
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


class DashboardPage:
    """One browser's view of the dashboard, read and clicked in one round trip each."""

    def __init__(self, page) -> None:
        self.page = page

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


def track_and_preview(page: DashboardPage, session) -> None:
    """Track target, then Preview throw, through the buttons; returns when Throw is enabled."""
    # With this browser's software rendering saturating a small machine, the real-time
    # simulation can starve the 100 Hz loop long enough for the alignment to lose the target
    # (no frame for its lost timeout) and stop with status "lost". The dashboard reports it and
    # the operator presses Track target again; so do the tests, up to three times. (The other
    # symptom of a starved loop, a command that starts behind the arm, the commander now
    # rebuilds itself: tests/test_alignment.py.)
    for _ in range(3):
        settle(session)
        before = session.alignment
        page.wait_button("Track target", True)
        page.click("Track target")
        wait_for(lambda: session.busy or session.alignment is not before, 5.0, "the alignment to start")  # noqa: B023 (called at once)
        wait_for(lambda: not session.busy, 40.0, "the alignment")
        if session.alignment is not before and session.alignment.converged:
            break
    assert session.alignment is not None and session.alignment.converged, session.alignment
    page.wait_button("Preview throw", True)
    page.click("Preview throw")
    wait_for(lambda: not session.busy and session.preview is not None, 20.0, "the preview")
    page.wait_button("Throw", True)


def test_page_loads_with_its_panels(browsers):
    page = browsers[0]
    buttons = page.buttons()
    for name in ("Stop", "Calibrate", "Track target", "Preview throw", "Throw", "Home"):
        assert name in buttons, f"no {name} button ({sorted(buttons)})"
    assert buttons["Stop"] and buttons["Calibrate"] and buttons["Track target"]
    assert not buttons["Throw"], "Throw needs a preview first"
    text = page.text()
    for title in ("Cameras", "Calibration", "Throw", "Last throws", "Mono vs stereo"):
        assert title in text
    # the calibration's figures: per-camera RMS, leave-one-out error, worst points
    assert "Leave-one-out 3D error" in text and "Worst points" in text
    assert re.search(r"cam0 \d+\.\d+ px, cam1 \d+\.\d+ px", text)
    # each camera's view says what it sees: both remotes see the target
    page.wait_text(r"cam0: 1 dot\b")
    page.wait_text(r"cam1: 1 dot\b")


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
    page.wait_text(r"Throw preview \d+\?")
    time.sleep(0.5)
    assert len(session.history) == before and not session.busy, "the throw must wait for the confirmation"
    page.click("Throw now")
    wait_for(lambda: len(session.history) > before and not session.busy, 30.0, "the throw")
    time.sleep(0.5)
    assert len(session.history) == before + 1
    record = session.history[-1]
    page.wait_text(rf"\b{record.index}\s+\d\d:\d\d:\d\d\s+{record.target_xz[0]:.3f}, {record.target_xz[1]:.3f}")
    if np.isfinite(record.error_m):
        page.wait_text(rf"\b{100 * record.error_m:.1f}\b")
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
    a.wait_text(r"Throw preview \d+\?")
    b.wait_text(r"Throw preview \d+\?")
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


def test_stop_halts_a_running_throw(browsers, live_dashboard):
    session = live_dashboard.session
    page = browsers[1]
    settle(session)
    page.click("Home")  # a throw from home winds up for about 1.5 s before the release
    wait_for(lambda: session.busy, 10.0, "the arm to go home")
    settle(session)
    track_and_preview(page, session)
    before = len(session.history)
    release = session.preview.throw.release_time
    page.click("Throw")
    page.wait_text(r"Throw preview \d+\?")
    page.click("Throw now")
    wait_for(lambda: session.operation == "throw", 15.0, "the throw to start")
    started = time.monotonic()
    page.click("Stop")
    wait_for(lambda: not session.busy, 5.0, "the throw to end")
    assert time.monotonic() - started < release, "Stop came too late for this test (after the release)"
    wait_for(lambda: not session.world.arm.is_moving(), 3.0, "the arm to come to rest")
    assert np.all(np.abs(session.world.arm.state().dq) < 1e-6)
    assert len(session.history) == before, "a stopped throw records no throw"
    page.wait_text("Throw did not complete")


def test_a_browser_closed_mid_throw_lets_the_throw_finish(chromium, browser_pages, live_dashboard):
    """The throw belongs to the server, not to the browser that confirmed it."""
    session = live_dashboard.session
    context = chromium.new_context(viewport={"width": 1280, "height": 860})
    page = DashboardPage(context.new_page())
    page.page.goto(live_dashboard.url)
    page.page.get_by_role("button", name="Stop", exact=True).wait_for(timeout=90_000)
    page.page.add_style_tag(content=SMALL_SCENE)
    track_and_preview(page, session)
    before = len(session.history)
    page.click("Throw")
    page.wait_text(r"Throw preview \d+\?")
    page.click("Throw now")
    wait_for(lambda: session.operation == "throw", 15.0, "the throw to start")
    context.close()  # the operator's browser goes away mid-throw
    wait_for(lambda: not session.busy, 30.0, "the throw to finish")
    assert len(session.history) == before + 1, "the throw finished and was recorded"
    wait_for(lambda: not session.world.arm.is_moving(), 5.0, "the arm to come to rest")
    wait_for(lambda: len(live_dashboard.server.get_clients()) == len(browser_pages), 10.0, "the client to leave")
