"""What the session's state says is true (issue 21, "true status everywhere"): a failed rig read is
cleared by the next read that succeeds; one calibration state, stated once (a loaded calibration,
a calibration under way: "calibrating: pose k/N", never "not calibrated" beside it); a throw
stopped after its release says stopped, with no error figure; no "nan" in any status text.
Asserted on `Session.snapshot()` and on the texts the dashboard shows of it (`wiithrow.web.panels`)."""

from __future__ import annotations

import threading
import time
from types import SimpleNamespace

import numpy as np
import pytest

from tests.conftest import wait_for
from tests.helpers.sim_fixtures import target_at
from wiithrow.app.session import Event, Operation, simulated_session, throw_outcome
from wiithrow.app.session.rig_loop import READ_FAILED, RigLoop
from wiithrow.app.session.status import BEFORE_MEASURING, LOADED, STOPPED_AFTER_RELEASE
from wiithrow.throwing.landing_error import UNKNOWN
from wiithrow.vision.errors import VisionError
from wiithrow.web.panels import calibration_summary, preview_text, status_text, throws_table

OLDER = "camera 0: frame at t=928.988578 s is older than the previous one"


def page_texts(session) -> str:
    """Everything the dashboard's panels write of the session's state now."""
    s = session.snapshot()
    calibrated = session.world.calibration is not None
    return "\n".join(
        (
            status_text(s, calibrated=calibrated),
            calibration_summary(s, [], calibrated=calibrated),
            preview_text(s),
            throws_table(s),
        )
    )


class FlakyRig:
    """A rig whose first `failures` polls raise what the race raised."""

    def __init__(self, failures: int) -> None:
        self.failures, self.polls = failures, 0

    def poll(self) -> None:
        self.polls += 1
        if self.polls <= self.failures:
            raise VisionError(OLDER)


def test_a_failed_rig_read_is_cleared_by_the_next_read_that_succeeds():
    messages: list[str] = []
    cleared = threading.Event()
    world = SimpleNamespace(rig=FlakyRig(failures=3), clock=SimpleNamespace(sleep=lambda s: time.sleep(0.001)))

    def clear(text: str) -> None:
        if messages and messages[-1] == text:
            messages.append("")
        cleared.set()

    loop = RigLoop(world, busy=lambda: False, tell=messages.append, clear_message=clear)  # type: ignore[arg-type]
    loop.start()
    try:
        assert cleared.wait(5.0), "a read that succeeds clears the failure"
    finally:
        loop.stop()
    assert messages == [READ_FAILED + OLDER, ""], "told once (the same error three times), then cleared"
    assert world.rig.polls > 3


def test_the_session_clears_a_stale_read_failure_and_keeps_a_newer_message():
    session = simulated_session(seed=3, calibration="true")
    rig = session.world.rig
    real_poll, calls, failing = rig.poll, [], threading.Event()

    def flaky_poll():
        calls.append(1)
        if failing.is_set():
            raise VisionError(OLDER)
        return real_poll()

    seen: list[str] = []
    session.subscribe(lambda event: seen.append(session.snapshot().message) if event is Event.MESSAGE else None)
    rig.poll = flaky_poll
    failing.set()
    session.start(period_s=0.01)
    try:
        wait_for(lambda: session.snapshot().message == READ_FAILED + OLDER, 10.0, "the failure to show")
        assert "rig read failed" in page_texts(session)
        failing.clear()
        wait_for(lambda: session.snapshot().message == "", 5.0, "the failure to clear")
        assert seen == [READ_FAILED + OLDER, ""], "told once, then cleared"
        assert "rig read failed" not in page_texts(session)
        # a failure, then a newer message: the reads that succeed leave the newer one
        failing.set()
        wait_for(lambda: session.snapshot().message == READ_FAILED + OLDER, 5.0, "a failure again")
        session.tell("the remote publisher restarted")
        failing.clear()
        n = len(calls)
        wait_for(lambda: len(calls) > n + 5, 10.0, "reads that succeed")
        assert session.snapshot().message == "the remote publisher restarted"
    finally:
        session.close()


def test_a_loaded_calibration_is_one_state_calibrated():
    """`serve --calibration`, `demo --calibration`, `replay --dashboard`: the rig tracks with a
    calibration the session did not make: "calibrated", never "Not calibrated: press Calibrate"."""
    session = simulated_session(seed=4, calibration="true")
    assert session.calibration_state() == LOADED
    text = page_texts(session)
    assert "Idle** · calibrated (loaded" in text
    assert "not calibrated" not in text.lower() and "nan" not in text


def test_a_calibration_under_way_says_its_pose_and_nothing_else():
    """The demo's automatic calibration (as the Calibrate button's): every state the page is shown
    while it runs says "calibrating: pose k/N" (k from 1 to N), never "not calibrated"."""
    session = simulated_session(seed=2, calibration=None)
    assert session.calibration_state() == "not calibrated"
    assert "Not calibrated: press **Calibrate**" in page_texts(session)
    states: list[tuple[str, str]] = []

    def on_event(event: Event) -> None:
        if session.operation is Operation.CALIBRATE:
            states.append((session.calibration_state(), page_texts(session)))

    session.subscribe(on_event)
    poses = 7
    result = session.calibrate(poses)
    session.unsubscribe(on_event)
    assert states, "the session told its listeners while it calibrated"
    for state, text in states:
        assert state.startswith("calibrating"), state
        assert "not calibrated" not in text.lower(), text
        assert text.count("calibrating") + text.count("Calibrating") >= 2, "the status line and the folder say it"
        assert "nan" not in text
    counted = [state for state, _ in states if state.startswith("calibrating: pose ")]
    assert counted[0] == f"calibrating: pose 1/{poses}" and counted[-1] == f"calibrating: pose {poses}/{poses}"
    assert session.calibration_state() == f"calibrated with the robot ({len(result.data)} poses)"
    text = page_texts(session)
    assert "Idle** · calibrated with the robot" in text and "not calibrated" not in text.lower()


class EightPoses:
    skipped = ()
    duration_s = 60.0

    def __len__(self) -> int:
        return 8


def test_worst_points_are_numbered_from_one():
    """As the command line and the README number poses ("Worst points: pose 0" was the first)."""
    calibration = SimpleNamespace(data=EightPoses(), rms_px=(0.5, 0.6), loo=SimpleNamespace(mean=0.002))
    s = SimpleNamespace(calibration=calibration, wand=None, operation=None, progress=("", 0.0))
    text = calibration_summary(s, [(0, 0.00714), (5, 0.003)], calibrated=True)  # type: ignore[arg-type]
    assert "pose 1: 7.14 mm, pose 6: 3.00 mm" in text and "pose 0" not in text


@pytest.fixture()
def aligned():
    session = simulated_session(seed=5, calibration="true")
    session.set_target(target_at(1.3, 0.2, 0.2))
    assert session.align().converged
    return session


def test_a_throw_stopped_after_its_release_says_stopped_with_no_error_figure(aligned):
    session = aligned
    preview = session.plan_preview()
    world = session.world
    after_open = world.after_open

    def stop_after_the_release() -> None:  # the operator presses Stop as the ball leaves the hand
        session.stop()
        after_open()

    world.after_open = stop_after_the_release
    record = session.throw(preview.id)
    world.after_open = after_open
    assert record.failure == STOPPED_AFTER_RELEASE and session.history[-1] is record
    assert np.isfinite(record.execution.landing_base).all(), "the ball flew: where it landed is kept"
    assert session.snapshot().message == STOPPED_AFTER_RELEASE
    text = page_texts(session)
    assert f"Last throw #{record.index}: stopped by the operator after the release" in text
    assert "error" not in preview_text(session.snapshot()) and " mm" not in preview_text(session.snapshot())
    row = throws_table(session.snapshot()).splitlines()[2]
    assert "**stopped** by the operator after the release" in row and f"{1000 * record.error_m:.1f} |" not in row
    assert "nan" not in text
    assert session.refusal(Operation.MEASURE_LANDING) is None, "the ball landed: its landing can be measured"


def test_an_unmeasured_throw_never_says_nan():
    """On hardware a throw's landing is unmeasured (NaN) until Measure landing: "error nan cm" was
    its error formatted without asking (the NaN distance of a NaN landing to the target)."""
    record = SimpleNamespace(
        index=2,
        wall_time="2026-01-01T12:00:00",
        target_xz=np.array([1.3, 0.2]),
        landing_xz=np.full(2, np.nan),
        error=UNKNOWN,  # the 3D error of an unmeasured landing
        true_error=None,
        failure=None,
        ball_lost=False,  # not lost in the wind-up
        execution=SimpleNamespace(release_late_s=None),  # released on time
        measured_again=False,
    )
    assert throw_outcome(record) == BEFORE_MEASURING  # type: ignore[arg-type]
    s = SimpleNamespace(history=(record,), preview=None, alignment=None, busy=False)
    assert "nan" not in preview_text(s) + throws_table(s)  # type: ignore[arg-type]
    assert preview_text(s) == f"Last throw #2: {BEFORE_MEASURING}"  # type: ignore[arg-type]
    assert "before measuring" in throws_table(s)  # type: ignore[arg-type]
