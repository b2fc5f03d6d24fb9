"""`wiithrow demo` as a person meets it (issue 21): the command itself, in its default world (MuJoCo),
in a subprocess, and a headless Chromium that only presses the page's buttons.

A guest's page comes first: it says guest and how to become an operator, every control it has is
disabled with that reason written in each folder, and it does not start the automatic
calibration, which waits for an operator's page (the terminal says so). The operator's page then
shows that calibration under way, "calibrating: pose k/N" up to N/N, never "not calibrated"
beside it, every button disabled meanwhile with the busy reason; then Track target, Preview throw, Throw with its confirmation, and the
landing is shown with its error. At each step every disabled button's reason is written in the
page, the same text as the session's refusal of that click (`wiithrow.app.session.refusals`), the
buttons without a reason are enabled, and no status says "nan".

The fewest calibration poses the dashboard accepts (7) are enough: Preview compares the target's
placements, not a measurement with the truth, so the throw needs no particular accuracy.
Chromium as in test_browser.py (software WebGL: the canvas shrunk, one round trip per check).
"""

from __future__ import annotations

import os
import re
import signal
import subprocess
import sys
import threading
import time
from collections.abc import Iterator

import pytest

from tests.conftest import PAGE_START_MS, small_scene_context, wait_for
from tests.web.test_browser import DashboardPage, reason_shown
from wiithrow.app.cli.serving import WAITING
from wiithrow.app.session import Operation, busy_reason
from wiithrow.app.session.refusals import PREVIEW_FIRST, THROW_FIRST, TRACK_FIRST
from wiithrow.web.controls import GUEST_BANNER, GUEST_REASON, label

pytestmark = [pytest.mark.browser, pytest.mark.slow]

#: The demo's calibration here: 10 poses (7 with the rig's mount 15 cm further back left the landing
#: marker untracked, "not measured", in three runs of three; the demo itself calibrates with 60).
POSES = 10
#: Every operation button of the page, the Wand panel's Start included.
BUTTONS = tuple(
    label(op)
    for op in (
        Operation.CALIBRATE,
        Operation.TRACK,
        Operation.PREVIEW,
        Operation.THROW,
        Operation.MEASURE_LANDING,
        Operation.HOME,
        Operation.CALIBRATE_WAND,
    )
)
#: Records, from the page's first script, every calibration pose the page showed, with the page's
#: text and the buttons' states then (the calibration is over in some 10 s: faster than a check
#: of the page by the test may be), and whether "not calibrated" ever stood beside a pose.
RECORD_POSES = """
window.__poses = [];
new MutationObserver(() => {
  const text = document.body ? document.body.textContent : '';
  const m = text.match(/calibrating: pose (\\d+)\\/(\\d+)/);
  if (m && (!window.__poses.length || window.__poses[window.__poses.length - 1].pose !== m[0])) {
    const disabled = {};
    document.querySelectorAll('button').forEach(b => { const t = b.textContent.trim(); if (t) disabled[t] = b.disabled; });
    window.__poses.push({pose: m[0], text: text, disabled: disabled});
  }
  if (m && /not calibrated/i.test(text)) window.__contradiction = text;
}).observe(document, {subtree: true, childList: true, characterData: true});  // no documentElement yet
"""


class Demo:
    """`wiithrow demo` running in a subprocess; its stdout lines as they come."""

    def __init__(self, *args: str) -> None:
        self.process = subprocess.Popen(
            [sys.executable, "-m", "wiithrow.app.cli.main", "demo", "--port", "0", *args],
            stdout=subprocess.PIPE,
            stderr=subprocess.STDOUT,
            text=True,
            env={**os.environ, "PYTHONUNBUFFERED": "1"},
        )
        self.lines: list[str] = []
        threading.Thread(target=self._read, daemon=True).start()

    def _read(self) -> None:
        assert self.process.stdout is not None
        for line in self.process.stdout:
            self.lines.append(line.rstrip("\n"))

    def wait_line(self, pattern: str, timeout_s: float) -> re.Match[str]:
        regex = re.compile(pattern)

        def found() -> re.Match[str] | None:
            if self.process.poll() is not None and not any(regex.search(line) for line in self.lines):
                pytest.fail(f"the demo ended ({self.process.returncode}): {self.lines[-10:]}")
            return next((m for line in self.lines if (m := regex.search(line))), None)

        return wait_for(found, timeout_s, f"{pattern!r} from the demo")

    def close(self) -> None:
        if self.process.poll() is None:
            self.process.send_signal(signal.SIGINT)  # Ctrl-C: stops the arm, closes
            try:
                self.process.wait(timeout=20.0)
            except subprocess.TimeoutExpired:
                self.process.kill()
                self.process.wait()


@pytest.fixture(scope="module")
def demo() -> Iterator[Demo]:
    running = Demo("--poses", str(POSES))
    try:
        yield running
    finally:
        running.close()


def open_page(chromium, url: str) -> DashboardPage:
    context = small_scene_context(chromium, viewport={"width": 1280, "height": 900})  # the scene small from the start
    context.add_init_script(RECORD_POSES)
    page = context.new_page()
    page.goto(url)
    page.get_by_role("button", name="Stop", exact=True).wait_for(timeout=PAGE_START_MS)
    return DashboardPage(page)


def expand_wand_folder(page: DashboardPage) -> None:
    """Open the Wand folder (collapsed by default) so that its Start button and reasons show."""
    shown = "() => document.body.innerText.includes('Start wand calibration')"  # shown, not only built
    click = """() => {
      const title = [...document.querySelectorAll('div')].find(
        e => [...e.childNodes].some(n => n.nodeType == 3 && n.textContent.trim() == 'Wand'));  // the folder's label
      if (title) title.click();
      return !!title;
    }"""
    for _ in range(3):
        if page.page.evaluate(shown):
            return
        assert page.page.evaluate(click), "no Wand folder in the page"
        try:
            wait_for(lambda: page.page.evaluate(shown), 10.0, "the Wand folder to open")
        except pytest.fail.Exception:
            continue
    assert page.page.evaluate(shown), "the Wand folder did not open"


def no_nan(text: str) -> None:
    assert not re.search(r"\bnan\b", text, re.IGNORECASE), f"'nan' in the page: {text[:400]}"


def check_reasons(page: DashboardPage, reasons: dict[str, str], timeout_s: float = 30.0) -> None:
    """Every button of `reasons` with a reason is disabled and its reason written in the page as
    "label: reason" (`reason_shown`); every one without ("") is enabled."""

    def shown() -> bool:
        text, buttons = page.text(), page.buttons()
        return all(
            (reason_shown(text, name, why) and buttons.get(name) is False) if why else buttons.get(name) is True
            for name, why in reasons.items()
        )

    try:
        wait_for(shown, timeout_s, f"the page to show {reasons}")
    except pytest.fail.Exception:
        text, buttons = page.text(), page.buttons()
        missing = {n: w for n, w in reasons.items() if w and not reason_shown(text, n, w)}
        pytest.fail(f"buttons {buttons}; reasons not in the page: {missing}")
    no_nan(page.text())


def test_the_demo_from_load_to_a_landing_with_its_error_through_the_page(chromium, demo):
    operator_url = demo.wait_line(r"wiithrow dashboard: (http://\S+\?token=\S+)", 180.0).group(1)
    guest_url = operator_url.split("?")[0]
    demo.wait_line(re.escape(WAITING.format(poses=POSES)), 10.0)

    # a guest first: told they are one, every control disabled with why; no calibration starts
    guest = open_page(chromium, guest_url)
    expand_wand_folder(guest)
    guest.wait_text(re.escape(GUEST_BANNER.split("**")[1]))
    guest.wait_text(re.escape("open the operator's link"))
    wait_for(lambda: guest.text().count(GUEST_REASON) >= 3, 20.0, "the guest's reason in every folder")
    buttons = guest.buttons()
    assert buttons["Stop"] and all(buttons.get(name) is False for name in BUTTONS), buttons
    assert buttons.get("Record") is False, "the Record toggle is an operator's"
    time.sleep(1.0)
    assert "Idle" in guest.text() and "calibrating" not in guest.text(), "a guest's page starts nothing"
    assert not any("calibrating (" in line for line in demo.lines)
    no_nan(guest.text())

    # the operator's page: the automatic calibration starts now, and the page shows it from pose 1
    operator = open_page(chromium, operator_url)
    demo.wait_line(r"an operator's page connected: calibrating", 30.0)
    operator.wait_text(re.escape("World: MuJoCo (simulated)"))  # the page says which world it drives
    expand_wand_folder(operator)
    operator.wait_text(r"Idle\s*·\s*calibrated with the robot", timeout_s=240.0)
    shown = operator.page.evaluate("() => window.__poses")
    poses = [s["pose"] for s in shown]
    # the page saw the calibration under way, in order, within its N poses. (From pose 1 to N when
    # the page renders a frame per pose: it processes the server's messages once per frame, and on
    # a loaded machine software WebGL took seconds per frame, so one run showed poses 5 and 7 only,
    # and another 1 to 6, the last pose's state replaced by "calibrated" before the page drew it.
    # That the calibration starts only once an operator's page connected, with pose 1 its first
    # state, is tests/web/test_dashboard.py's test_the_demos_automatic_calibration_waits...)
    counted = [int(p.split()[-1].split("/")[0]) for p in poses]
    assert counted and counted == sorted(set(counted)), f"the page showed {poses}"
    assert counted[0] >= 1 and counted[-1] <= POSES and all(p.endswith(f"/{POSES}") for p in poses), poses
    contradiction = operator.page.evaluate("() => window.__contradiction || ''")
    assert not contradiction, f"'not calibrated' beside a pose: {contradiction[:300]}"
    busy = busy_reason(Operation.CALIBRATE)
    for state in shown:  # while it ran, every operation button disabled, saying why
        for name in BUTTONS:
            assert state["disabled"][name] and reason_shown(state["text"], name, busy), (state["pose"], name)
        assert not state["disabled"]["Record"] and not state["disabled"]["Stop"]
    assert "Not calibrated" not in operator.text()
    check_reasons(
        operator,
        {
            "Calibrate": "",
            "Track target": "",
            "Preview throw": TRACK_FIRST,
            "Throw": PREVIEW_FIRST,
            "Measure landing": THROW_FIRST,
            "Home": "",
            "Start wand calibration": "",
        },
    )
    # the guest sees the same state, their controls still disabled
    guest.wait_text(r"Idle\s*·\s*calibrated with the robot", timeout_s=30.0)
    assert all(guest.buttons().get(name) is False for name in BUTTONS)

    # Track target (again if a starved real-time loop lost the target: the page says so)
    for attempt in range(3):
        operator.click("Track target", timeout_s=60.0)
        try:  # aligned: Preview is enabled (a page's queries take seconds here)
            operator.wait_button("Preview throw", True, timeout_s=90.0)
            break
        except pytest.fail.Exception:
            if attempt == 2:
                raise
    operator.wait_text(r"Target in the throw plane: x \d\.\d{3} m, z -?\d\.\d{3} m", timeout_s=10.0)
    check_reasons(operator, {"Preview throw": "", "Throw": PREVIEW_FIRST, "Measure landing": THROW_FIRST})

    # Preview, then Throw with its confirmation
    operator.click("Preview throw", timeout_s=30.0)
    operator.wait_text(r"Preview 1\b", timeout_s=60.0)
    check_reasons(operator, {"Throw": "", "Measure landing": THROW_FIRST})
    operator.click("Throw", timeout_s=30.0)
    operator.wait_text(r"Throw \(preview 1\): throw it\?", timeout_s=30.0)
    assert "Last throw #" not in operator.text() and "No throws yet" in operator.text(), "it waits for the confirmation"
    operator.click("Throw now", timeout_s=30.0)

    # the landing, shown with its error
    try:
        error_mm = float(operator.wait_text(r"Last throw #1: error \d+\.\d mm", timeout_s=120.0).split()[-2])
    except pytest.fail.Exception:
        shown = re.findall(r"(?:Idle|Throw\b|Last throw)[^\n]*", operator.text())
        pytest.fail(f"no landing with its error in the page; it shows {shown[:6]}; the demo: {demo.lines[-5:]}")
    # shown, not judged: with 7 poses on MuJoCo's arm the measured miss was 11 cm (the accuracy of
    # the user's path is issue 21's item 4); the bound says the ball came down by the target
    assert 0.0 <= error_mm < 250.0, f"the demo's throw missed by {error_mm} mm"
    operator.wait_text(  # the table's row: its error along / across / total (mm), the total the same
        rf"\b1\s+\d\d:\d\d:\d\d\s+\d\.\d{{3}}, -?\d\.\d{{3}}\s+\d\.\d{{3}}, -?\d\.\d{{3}}\s+"
        rf"[+-]\d+\.\d / [+-]\d+\.\d / {error_mm}\b"
    )
    check_reasons(operator, {"Throw": PREVIEW_FIRST, "Measure landing": "", "Track target": ""})
    guest.wait_text(r"Last throw #1: error \d+\.\d mm", timeout_s=30.0)
    no_nan(guest.text())
    for page in (operator, guest):
        page.page.context.close()
