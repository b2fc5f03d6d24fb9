"""The dashboard never waits for a polling rig (`wiithrow.web.live.read_rig`: while the rig holds
its lock, a refresh draws the previous reading), refreshes between the rig's polls on the system
clock (`wiithrow.web.poll_phase.PollPhase`) and shortens the interpreter's switch interval only
while it serves (`wiithrow.web.throttle.SwitchInterval`)."""

from __future__ import annotations

import sys
import threading
import time

import pytest

from wiithrow.app.session import demo_target_base, simulated_session
from wiithrow.web.live import RigReading, read_rig
from wiithrow.web.throttle import SWITCH_INTERVAL_S, SwitchInterval


class _Holder:
    """Holds `lock` in a thread of its own until `release()`."""

    def __init__(self, lock: threading.RLock) -> None:
        self.held, self._release = threading.Event(), threading.Event()
        self.thread = threading.Thread(target=self._hold, args=(lock,), daemon=True)
        self.thread.start()
        assert self.held.wait(5.0), "the holder never took the lock"

    def _hold(self, lock: threading.RLock) -> None:
        with lock:
            self.held.set()
            self._release.wait(30.0)

    def release(self) -> None:
        self._release.set()
        self.thread.join(5.0)


@pytest.fixture(scope="module")
def dashboard():
    from wiithrow.web.server import Dashboard

    session = simulated_session(seed=3, calibration="true", quiet=True)
    session.set_target(demo_target_base())
    for _ in range(20):  # a few polls: tracked frames and camera frames to read
        session.world.clock.sleep(0.01)
        session.world.rig.poll()
    dash = Dashboard(session, port=0, analysis_process=False)
    yield dash
    dash.close()
    session.close()


def test_a_refresh_while_the_rig_polls_draws_the_previous_reading_without_waiting(dashboard):
    rig = dashboard.world.rig
    dashboard.refresh()
    first = dashboard.rig_reading
    assert first is not None and first.fresh and first.tracked is not None
    assert len(first.frames) == len(rig.camera_names) and all(f is not None for f in first.frames)
    holder = _Holder(rig.lock)  # the rig "polls" in another thread
    try:
        refresh = threading.Thread(target=dashboard.refresh, daemon=True)
        refresh.start()
        refresh.join(10.0)
        assert not refresh.is_alive(), "a refresh waited for the rig's lock"
        assert holder.thread.is_alive(), "the rig's lock was released before the refresh returned"
        stale = dashboard.rig_reading
        assert stale is not None and not stale.fresh
        assert stale.tracked is first.tracked and stale.frames == first.frames
    finally:
        holder.release()
    dashboard.refresh()
    assert dashboard.rig_reading is not None and dashboard.rig_reading.fresh


def test_the_first_reading_waits_for_the_rig(dashboard):
    rig = dashboard.world.rig
    holder = _Holder(rig.lock)
    got: list[RigReading] = []
    reader = threading.Thread(target=lambda: got.append(read_rig(rig, None)), daemon=True)
    try:
        reader.start()
        reader.join(0.2)
        assert reader.is_alive() and not got, "with no previous reading, read_rig did not wait for the rig"
    finally:
        holder.release()
    reader.join(10.0)
    assert len(got) == 1 and got[0].fresh and got[0].tracked is rig.latest_tracked()


def test_the_switch_interval_is_short_while_serving_and_put_back_after():
    before = sys.getswitchinterval()
    interval = SwitchInterval()
    try:
        interval.apply()
        assert sys.getswitchinterval() == pytest.approx(SWITCH_INTERVAL_S)
        interval.apply()  # twice: still the one from before is put back
        interval.restore()
        assert sys.getswitchinterval() == pytest.approx(before)
        interval.apply()
        sys.setswitchinterval(0.002)  # someone else's since: theirs stays
        interval.restore()
        assert sys.getswitchinterval() == pytest.approx(0.002)
    finally:
        sys.setswitchinterval(before)
    with pytest.raises(ValueError, match="interval_s must be > 0, got 0"):
        SwitchInterval(0.0)


# -- the refresh follows the rig's polls (`wiithrow.web.poll_phase`) ------------------------------------


def _pipeline(clock):
    from wiithrow.app.rig.pipeline import TrackingPipeline

    return TrackingPipeline(["cam0", "cam1"], clock)


def test_a_poll_phase_returns_when_the_rigs_next_poll_ends():
    from wiithrow.clock import SystemClock
    from wiithrow.web.poll_phase import PollPhase

    pipeline = _pipeline(SystemClock())
    phase = PollPhase(pipeline, timeout_s=5.0, after_s=0.0)
    assert phase.following and len(pipeline.events) == 1
    ended: list[bool] = []
    waiter = threading.Thread(target=lambda: ended.append(phase.wait()))
    waiter.start()
    waiter.join(0.2)
    assert waiter.is_alive(), "the wait returned before any poll ended"
    pipeline.flush(pipeline.clock.now())  # the end of a poll: its `Flushed` event
    waiter.join(5.0)
    assert ended == [True] and (phase.aligned, phase.timed_out) == (1, 0)
    phase.close()
    phase.close()
    assert len(pipeline.events) == 0 and not phase.following


def test_a_poll_phase_gives_up_after_its_timeout_and_follows_no_simulated_clock():
    from wiithrow.clock import SimClock, SystemClock
    from wiithrow.web.poll_phase import PollPhase

    phase = PollPhase(_pipeline(SystemClock()), timeout_s=0.05)
    assert not phase.wait()  # no poll: the refresh goes ahead
    assert (phase.aligned, phase.timed_out) == (0, 1)
    phase.close()
    simulated = _pipeline(SimClock())
    phase = PollPhase(simulated)
    assert not phase.following and len(simulated.events) == 0  # (a listener would cost it its skipped reads)
    assert not phase.wait() and (phase.aligned, phase.timed_out) == (0, 0)
    with pytest.raises(ValueError, match="timeout_s must be > 0, got 0"):
        PollPhase(simulated, timeout_s=0.0)
    with pytest.raises(ValueError, match="after_s must be >= 0, got -1"):
        PollPhase(simulated, after_s=-1.0)


def test_a_serving_dashboard_on_the_system_clock_refreshes_between_the_rigs_polls():
    from wiithrow.web.server import Dashboard

    session = simulated_session(seed=3, calibration="true", quiet=True, realtime=True)
    dash = Dashboard(session, port=0, analysis_process=False, derived_figures=False)
    try:
        dash.start()  # the session's rig loop (a poll every 10 ms) and the refresh thread (20 Hz)
        phase = dash.poll_phase
        assert phase is not None and phase.following
        deadline = time.monotonic() + 30.0
        while phase.aligned < 10 and time.monotonic() < deadline:
            time.sleep(0.05)
        assert phase.aligned >= 10, f"{phase.aligned} refreshes after a poll, {phase.timed_out} timed out"
    finally:
        dash.close()
        session.close()
    assert dash.poll_phase is None and len(session.world.rig.events) == 0


def test_a_poll_phase_returns_after_s_after_the_polls_end():
    from wiithrow.clock import SystemClock
    from wiithrow.web.poll_phase import AFTER_POLL_S, PollPhase

    pipeline = _pipeline(SystemClock())
    phase = PollPhase(pipeline, timeout_s=5.0)
    assert phase.after_s == AFTER_POLL_S > 0
    returned: list[float] = []
    waiter = threading.Thread(target=lambda: (phase.wait(), returned.append(time.monotonic())))
    waiter.start()
    waiter.join(0.2)
    ended = time.monotonic()
    pipeline.flush(pipeline.clock.now())
    waiter.join(5.0)
    phase.close()
    assert returned and returned[0] - ended >= AFTER_POLL_S  # (a lower bound: sleeping never ends early)
