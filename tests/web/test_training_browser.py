"""The Training panel in a real browser (headless Chromium through Playwright), on the kinematic
world in real time with its true calibration: an operator starts a run of 5 throws, previews,
confirms and throws, measures the landing (the simulated operator puts the marker down); a Stop
mid-throw leaves the run at that throw, failed; the server restarts (a new world, session and
Dashboard on the same progress file) and the page, opened again, shows the run where it was; the
throw is retried, the rest thrown and measured, Finish fits, checks and saves the library and
shows it beside the one in use (a 5-throw library is not better than the shipped one: the dialog
says so), the operator uses it anyway, and the new session throws with it. A guest sees the panel with every training button disabled, saying why.

The pages' scene is shrunk to a thumbnail (software WebGL, see tests/web/test_browser.py)."""

from __future__ import annotations

import re

import numpy as np
import pytest

from tests.conftest import PAGE_START_MS, small_scene_context, wait_for
from tests.web.test_browser import DashboardPage, reason_shown
from wiithrow.app.session import Operation, simulated_session
from wiithrow.app.throws.library_file import load_library
from wiithrow.app.throws.training_file import load_run, progress_path
from wiithrow.web.controls import GUEST_REASON

pytestmark = pytest.mark.browser

THROWS = 5  # the fewest a library is fitted from (`training_run.MIN_MEASURED`)


class Served:
    """A dashboard on a fresh real-time session that trains to `library` (a server's life)."""

    def __init__(self, library) -> None:
        from wiithrow.web.server import Dashboard

        self.session = simulated_session(seed=2, calibration="true", realtime=True, quiet=True)
        self.session.train_to(library)
        self.dashboard = Dashboard(
            self.session, port=0, derived_figures=False, analysis_process=False, plain_scene=True
        )  # tests/conftest.py's PLAIN_SCENE
        self.told: list[tuple[str, str]] = []  # (title, body) of what the operations told the pages
        runner, notify = self.dashboard.runner, self.dashboard.runner.notify

        def telling(client, title: str, body: str, color) -> None:
            self.told.append((title, body))
            notify(client, title, body, color)

        runner.notify = telling
        self.dashboard.start()

    def close(self) -> None:
        self.session.stop()
        self.dashboard.runner.join(timeout=10.0)
        self.dashboard.close()
        self.session.close()


#: Click the button named `name` in the open dialog (a DOM click, as `DashboardPage.click`).
CLICK_IN_DIALOG = """name => {
  const dialog = document.querySelector('.mantine-Modal-content');
  if (!dialog) return 'no dialog';
  const b = [...dialog.querySelectorAll('button')].find(e => e.textContent.trim() == name);
  if (!b) return 'missing';
  b.click();
  return 'clicked';
}"""

#: Click the Training folder's title (a DOM click: Playwright's own waits for animation frames).
OPEN_FOLDER = """() => {
  const title = [...document.querySelectorAll('div')].find(e => e.style.cursor === 'pointer' && e.textContent.trim() === 'Training');
  if (!title) return false;
  title.click();
  return true;
}"""


def open_folder(page) -> None:
    wait_for(lambda: page.evaluate(OPEN_FOLDER), 30.0, "the Training folder's title")


def open_page(context, url: str) -> DashboardPage:
    page = context.new_page()
    dashboard = DashboardPage(page)
    dashboard.follow_connection()
    page.goto(url)
    page.get_by_role("button", name="Stop", exact=True).wait_for(timeout=PAGE_START_MS)
    page.evaluate(
        "css => { const e = document.createElement('style'); e.textContent = css; document.head.appendChild(e); }",
        ".mantine-Notification-root { display: none !important; }",
    )
    open_folder(page)
    wait_for(lambda: "Start training" in dashboard.buttons(), 30.0, "the Training panel's buttons")
    return dashboard


def idle(session) -> None:
    wait_for(lambda: not session.busy and not session.world.arm.is_moving(), 30.0, "the system to be idle")


def throw_once(page: DashboardPage, session) -> None:
    """Preview training throw, Throw (training), Throw now: returns once the throw operation ran."""
    idle(session)
    page.click("Preview training throw", timeout_s=30.0)
    wait_for(lambda: session.snapshot().training_preview is not None and not session.busy, 30.0, "the preview")
    page.click("Throw (training)", timeout_s=30.0)
    page.click("Throw now", timeout_s=30.0)
    wait_for(lambda: session.operation is Operation.TRAIN_THROW, 20.0, "the training throw to start")


def throw_and_measure(page: DashboardPage, served: Served, n: int) -> None:
    """Throw training throw `n` and measure its landing from the page. A throw whose hand the host
    opened late (its release warning: a loaded machine) may land where the rig sees no marker; the
    operator then does what the warning says, Retry throw, and throws it again (at most twice)."""
    session = served.session
    for attempt in range(3):
        throw_once(page, session)
        page.wait_text(rf"throw {n}/{THROWS} \(thrown\)", timeout_s=40.0)
        idle(session)
        if measure(page, served, n):
            break
        current = session.snapshot().training.current
        failure = served.told[-1] if served.told else None
        assert current is not None and current.release_warning and attempt < 2, (
            f"throw {n}'s landing was not measured ({failure}), its release warning: {current and current.release_warning!r}"
        )
        page.click("Retry throw", timeout_s=30.0)
        page.wait_text(rf"throw {n}/{THROWS} · measured {n - 1}", timeout_s=30.0)
    assert session.snapshot().training.measured == n, session.last_message
    page.wait_text(rf"(throw {n + 1}/{THROWS}|all {THROWS} throws done) · measured {n}", timeout_s=30.0)


def measure(page: DashboardPage, served: Served, n: int) -> bool:
    """Click Measure training landing; True once the landing of throw `n` is measured, False when
    the measurement told it did not complete."""
    session = served.session
    told = len(served.told)
    page.click("Measure training landing", timeout_s=30.0)

    def failed() -> bool:
        return any("did not complete" in title for title, _ in served.told[told:])

    wait_for(
        lambda: session.snapshot().training.measured == n or failed(),
        30.0,
        f"the landing of throw {n} measured",
        explain=lambda: what_the_system_says(page, served),
    )
    return session.snapshot().training.measured == n


def what_the_system_says(page: DashboardPage, served: Served) -> str:
    """The session's, the operations' and the page's state, for a wait that timed out."""
    session, runner = served.session, served.dashboard.runner
    return (
        f"the session says {session.last_message!r}; busy {session.busy} ({session.operation}); "
        f"operations started {runner.started}, refused {runner.refused}, running {runner.running}; "
        f"refusals {list(served.dashboard.refusals.recent)[-3:]}; the operations told {served.told[-3:]}; "
        f"clients connected (id: role) {served.dashboard.clients.roles}; the page's last events {page.events[-6:]}; "
        f"the page's buttons {page.buttons()}; its text {page.text()[-1500:]!r}"
    )


def test_training_from_the_panel_survives_a_stop_and_a_restart(chromium, tmp_path):
    library = tmp_path / "trained.json"
    context = small_scene_context(chromium)  # (its pages: the scene small from their start)
    served = Served(library)
    try:
        page = open_page(context, served.dashboard.operator_url)
        session = served.session
        page.wait_text("No training running")
        text = page.text()
        assert reason_shown(text, "Preview training throw", "no training running")  # a disabled button says why
        assert page.buttons()["Preview training throw"] is False
        page.wait_button("Start training", True, timeout_s=30.0)  # and so the inputs, which follow it
        count = page.page.get_by_label("Throws")
        count.fill(str(THROWS))
        count.press("Tab")
        wait_for(
            lambda: all(int(i.count.value) == THROWS for i in served.dashboard.training._inputs.values()),
            10.0,
            "the number of throws to reach the server",
        )
        page.click("Start training")
        page.wait_text(rf"throw 1/{THROWS} · measured 0 · skipped 0", timeout_s=30.0)
        assert progress_path(library).exists()
        throw_and_measure(page, served, 1)

        # throw 2: Stop while the arm winds up; the run stays at throw 2, failed. (A page's click can
        # take seconds on a loaded machine: a Stop that arrives after the release stops the return
        # home instead, and the throw is thrown; then Retry and stop the next one.)
        for _ in range(3):
            throw_once(page, session)
            page.click("Stop", timeout_s=5.0)
            wait_for(lambda: session.operation is not Operation.TRAIN_THROW, 30.0, "the throw to end")
            if session.snapshot().training.current.state == "failed":
                break
            page.wait_text(rf"throw 2/{THROWS} \(thrown\)", timeout_s=30.0)
            idle(session)
            page.click("Retry throw")
        page.wait_text(rf"throw 2/{THROWS} \(failed\) · measured 1", timeout_s=30.0)
        saved = load_run(progress_path(library), library)
        assert saved is not None and saved.index == 1 and saved.throws[1].state == "failed"
        idle(session)
        wait_for(
            lambda: reason_shown(page.text(), "Preview training throw", "throw 2 did not complete"),
            20.0,
            "Preview training throw's reason in the page",
        )

        # the server restarts: a new world, session and dashboard on the same progress file
        page.page.close()
        served.close()
        served = Served(library)
        session = served.session
        assert session.snapshot().training is not None
        page = open_page(context, served.dashboard.operator_url)
        page.wait_text(rf"throw 2/{THROWS} \(failed\) · measured 1 · skipped 0", timeout_s=30.0)
        page.click("Retry throw")
        page.wait_text(rf"throw 2/{THROWS} · measured 1", timeout_s=20.0)
        for n in range(2, THROWS + 1):
            throw_and_measure(page, served, n)
        idle(session)
        run = session.snapshot().training
        assert run is not None and run.complete
        page.click("Finish training", timeout_s=30.0)
        # Finish compares the new library with the one in use, in a dialog: the operator chooses it
        wait_for(
            lambda: page.page.evaluate(CLICK_IN_DIALOG, "Use the new library anyway") == "clicked",
            60.0,
            "the comparison's dialog",
            explain=lambda: what_the_system_says(page, served),
        )
        wait_for(  # (a CI run timed out here once, 2026-12-05, saying nothing more)
            lambda: "Trained library in use" in page.text(),
            60.0,
            "'Trained library in use' on the page",
            explain=lambda: what_the_system_says(page, served),
        )
        text = page.text()
        assert re.search(r"held-out error \(leave-one-out\) mean \d+\.\d mm", text), text
        assert f"{THROWS} measured landings" in text
        saved_library = load_library(library)
        assert not progress_path(library).exists()
        assert saved_library.to_dict() == session.library.to_dict()  # the new library is in use
        assert len(saved_library) == THROWS
        # each label is the rig's measurement of where that ball came down (the world's truth, in
        # link1's throw plane; true calibration, the simulated operator's placement error: < 2 cm).
        # Not necessarily near its target: a loaded machine can open the hand late in real time,
        # and the label is where the ball went, as in the paper.
        world = session.world
        truth = np.array([world.base_to_link1(t.landing_base, world.arm_model.home)[0][[0, 2]] for t in run.throws])
        assert np.max(np.linalg.norm(saved_library.landings - truth, axis=1)) < 0.02
        assert page.buttons()["Start training"] is True

        # a guest sees the panel, every training button disabled with the guest's reason
        guest = small_scene_context(chromium).new_page()
        guest.goto(served.dashboard.url)
        guest.get_by_role("button", name="Stop", exact=True).wait_for(timeout=PAGE_START_MS)
        open_folder(guest)
        viewer = DashboardPage(guest)
        viewer.wait_text("Trained library in use", timeout_s=30.0)
        buttons = viewer.buttons()
        for name in ("Start training", "Preview training throw", "Finish training"):
            assert buttons.get(name) is False, (name, buttons)
        assert GUEST_REASON in viewer.text()
    finally:
        served.close()
        context.close()
