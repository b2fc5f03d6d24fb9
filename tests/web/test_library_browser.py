"""The user's sequence of issue 43 on `wiithrow demo` (what `make demo` runs: the MuJoCo world, the
robot calibration started by the operator's page), in a headless Chromium that only presses the
page's buttons: five throws at the demo's target with the library in use (the shipped one, learning
on); a short training (5 throws over x 1.20-1.40 m, z 0.00-0.20 m); *Finish training* ends with the
dialog that shows the new library beside the one in use, and the new one is not better; one click on
*Keep the library in use*; the next throw lands as near as the five before. The library folder
(`--library-folder`) then holds the trained library as a version that is not in use, and the
learning's versions, the newest in use.

On main, Finish put the 5-throw library in use without a word (its held-out error 17 mm against the
shipped library's 1.8 mm, tests/app/test_library_guard.py), and the next throw was the new one's.
Chromium as in test_browser.py (software WebGL: the canvas shrunk, one round trip per check)."""

from __future__ import annotations

import re
import time

import pytest

from tests.conftest import wait_for
from tests.web.test_browser_demo import Demo, open_page
from tests.web.test_training_browser import CLICK_IN_DIALOG, open_folder
from wiithrow.app.throws.library_store import LibraryStore

pytestmark = [pytest.mark.browser, pytest.mark.slow]

THROWS = 5
#: How much farther (mm) than the worst of the five throws before the next one may land: the MuJoCo
#: world's release jitter (3 ms) and the marker's placement (5 mm) spread the demo's landings by about
#: a centimetre; a library of 5 throws over another area misses by 35 mm.
AS_GOOD_MM = 10.0


def throw_at_the_target(page, n: int) -> float:
    """Preview throw (Track target first when the alignment no longer holds), Throw, Throw now: the
    error (mm) of throw `n` the page shows."""
    if not page.buttons().get("Preview throw"):
        for attempt in range(3):  # again if a starved real-time loop lost the target (the page says so)
            page.click("Track target", timeout_s=60.0)
            try:
                page.wait_button("Preview throw", True, timeout_s=90.0)
                break
            except pytest.fail.Exception:
                if attempt == 2:
                    raise
    page.click("Preview throw", timeout_s=30.0)
    try:  # Throw is disabled until a preview is made (a throw uses its preview once)
        page.wait_button("Throw", True, timeout_s=90.0)
    except pytest.fail.Exception:
        pytest.fail(f"throw {n} not previewed; the page: {page.text()[-1500:]}")
    page.click("Throw", timeout_s=30.0)
    page.click("Throw now", timeout_s=30.0)
    shown = page.wait_text(rf"Last throw #{n}: error \d+\.\d mm", timeout_s=120.0)
    return float(shown.split()[-2])


#: viser 1.1's page sends its GUI inputs' changes through one sender that keeps only the latest
#: message for 50 ms (WebsocketUtils.makeThrottledMessageSender, shared by a container's inputs): a
#: field typed within 50 ms of another is lost. A person never types that fast; the test waits this
#: long (s) after each field.
BETWEEN_FIELDS_S = 0.3


def set_number(page, label: str, value: float) -> None:
    field = page.page.get_by_label(label, exact=True)
    field.fill(str(value))
    field.press("Tab")
    time.sleep(BETWEEN_FIELDS_S)


def test_a_short_training_is_compared_and_the_operator_keeps_the_library_in_use(chromium, tmp_path):
    folder = tmp_path / "library"
    demo = Demo("--plain-scene", "--library-folder", str(folder))  # the demo's calibration: 30 poses
    try:
        url = demo.wait_line(r"wiithrow dashboard: (http://\S+\?token=\S+)", 180.0).group(1)
        page = open_page(chromium, url)
        page.wait_text(r"Idle\s*·\s*calibrated with the robot", timeout_s=400.0)

        # five throws at the demo's target with the library in use
        errors = [throw_at_the_target(page, n) for n in range(1, THROWS + 1)]
        store = LibraryStore(folder)
        learned = store.in_use_record()
        assert learned is not None and learned.id > 1, "the throws did not join the library in use"

        # a short training over a small area
        open_folder(page.page)
        page.wait_button("Start training", True, timeout_s=30.0)
        for label, value in (("x min (m)", 1.2), ("x max (m)", 1.4), ("z min (m)", 0.0), ("z max (m)", 0.2)):
            set_number(page, label, value)
        set_number(page, "Throws", THROWS)
        page.click("Start training", timeout_s=30.0)
        page.wait_text(rf"throw 1/{THROWS} · measured 0", timeout_s=60.0)
        page.wait_text(r"area x 1\.20-1\.40 m, z 0\.00-0\.20 m", timeout_s=10.0)  # the area typed, as the run has it
        for n in range(1, THROWS + 1):
            for attempt in range(3):  # a throw whose landing the rig did not see is retried
                page.click("Preview training throw", timeout_s=60.0)
                page.wait_button("Throw (training)", True, timeout_s=60.0)
                page.click("Throw (training)", timeout_s=30.0)
                page.click("Throw now", timeout_s=30.0)
                page.wait_text(rf"throw {n}/{THROWS} \((thrown|failed)\)", timeout_s=120.0)
                if re.search(rf"throw {n}/{THROWS} \(thrown\)", page.text()):
                    page.click("Measure training landing", timeout_s=60.0)
                    try:
                        page.wait_text(rf"measured {n}\b", timeout_s=60.0)
                        break
                    except pytest.fail.Exception:
                        pass
                assert attempt < 2, f"training throw {n} was never measured: {page.text()[-800:]}"
                page.click("Retry throw", timeout_s=30.0)

        # Finish: the dialog with both libraries side by side; the new one is not better
        page.click("Finish training", timeout_s=60.0)
        dialog = page.wait_text(r"The trained library against the one in use", timeout_s=120.0)
        assert dialog
        text = page.text()
        assert "the new library" in text and re.search(r"version \d+ \(in use\)", text), text[-1500:]
        for row in ("held-out error, mean", "area covered", "throws (its area needs)"):
            assert row in text, row
        assert "the new library is not better" in text and "not put in use unless you choose it" in text
        wait_for(lambda: page.page.evaluate(CLICK_IN_DIALOG, "Keep the library in use") == "clicked", 30.0, "Keep")
        page.wait_text(r"Trained library kept, not in use", timeout_s=60.0)

        # the library in use stayed; the trained one is a version, not in use
        record = store.in_use_record()
        trained = [v for v in store.versions() if v.how == "training"]
        assert len(trained) == 1 and trained[0].throws == THROWS and trained[0].by == "operator"
        assert record.id != trained[0].id and record.id >= learned.id

        # the next throw is as good as the five before
        after = throw_at_the_target(page, THROWS + 1)
        print(f"\nthe five throws: {errors} mm; after the training, kept out of use: {after} mm")
        assert after <= max(errors) + AS_GOOD_MM, (errors, after)
        page.page.context.close()
    finally:
        demo.close()
