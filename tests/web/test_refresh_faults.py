"""A driver fault does not stop the dashboard: when the arm's `state()` starts raising mid-run the
refresh says so in one line (stderr and a notification), draws the arm at its last known pose
marked as such, and keeps drawing the rig's markers; a step of the refresh that raises every tick
is one line, not a traceback per tick, and the refresh thread goes on."""

from __future__ import annotations

import threading
import time

import numpy as np
import pytest

from wiithrow.app.session import demo_target_base, simulated_session

FAULT = "driver fault: the servo link is down"


@pytest.fixture
def dashboard():
    from wiithrow.web.server import Dashboard

    session = simulated_session(seed=5, calibration="true", quiet=True)
    session.set_target(demo_target_base())
    dash = Dashboard(session, port=0, analysis_process=False)
    yield dash
    dash.close()
    session.close()


def _run(dash, refreshes: int) -> None:
    """`refreshes` refreshes, the rig polled between them (the world's clock moved 10 ms each)."""
    for _ in range(refreshes):
        dash.world.clock.sleep(0.01)
        dash.world.rig.poll()
        dash.refresh()


def _newest_marker_t(dash) -> float:
    return max((t for trail in dash.scene._trail.values() for t, _ in trail), default=-np.inf)


def test_an_arm_whose_state_raises_mid_run_is_one_line_and_the_markers_go_on(dashboard, capfd, monkeypatch):
    dash = dashboard
    _run(dash, 20)
    q_before = np.asarray(dash.world.arm.state().q, dtype=float)
    assert np.isfinite(_newest_marker_t(dash)), "no tracked marker drawn before the fault"
    capfd.readouterr()

    def broken_state():
        raise RuntimeError(FAULT)

    monkeypatch.setattr(dash.world.arm, "state", broken_state)
    t_fault = _newest_marker_t(dash)
    _run(dash, 30)
    err = capfd.readouterr().err

    assert "Traceback" not in err, err
    lines = err.strip().splitlines()
    assert len(lines) == 1, lines  # 30 refreshes of one fault: one line
    assert lines[0].startswith("wiithrow dashboard refresh: the arm's state cannot be read: RuntimeError: " + FAULT)
    assert "last known pose" in lines[0]
    assert dash.scene.arm_stale_text is not None and FAULT in dash.scene.arm_stale_text  # marked in the scene
    assert dash._live is not None and np.array_equal(dash._live.q, q_before)  # drawn where it last was
    assert _newest_marker_t(dash) >= t_fault + 0.25  # the markers kept updating: 30 polls of 10 ms later
    assert dash.refresh_errors == 0  # no refresh failed as a whole

    monkeypatch.undo()  # the driver answers again: the mark goes
    _run(dash, 2)
    assert dash.scene.arm_stale_text is None and capfd.readouterr().err == ""


def test_a_step_that_raises_every_tick_is_one_line_and_the_refresh_thread_goes_on(dashboard, capfd, monkeypatch):
    dash = dashboard
    _run(dash, 5)
    capfd.readouterr()

    def broken_target(position):
        raise ValueError("a drawing bug")

    monkeypatch.setattr(dash.scene, "update_target", broken_target)
    dash.poll_phase = None  # the refresh thread alone, its ticks on the system clock
    thread = threading.Thread(target=dash._loop, daemon=True)
    thread.start()
    deadline = time.monotonic() + 60.0
    while dash.refresh_errors < 10 and time.monotonic() < deadline:
        time.sleep(0.05)
    dash._stop.set()
    thread.join(10.0)
    err = capfd.readouterr().err
    assert dash.refresh_errors >= 10, f"{dash.refresh_errors} refreshes in 60 s"
    assert not thread.is_alive()
    assert "Traceback" not in err and err.strip().splitlines() == [
        "wiithrow dashboard refresh: ValueError: a drawing bug (the dashboard goes on)"
    ], err
    assert dash.refresh_faults.count == dash.refresh_errors
