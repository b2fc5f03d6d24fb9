"""The dashboard never waits for a polling rig (`wiithrow.web.live.read_rig`: while the rig holds
its lock, a refresh draws the previous reading) and shortens the interpreter's switch interval only
while it serves (`wiithrow.web.throttle.SwitchInterval`)."""

from __future__ import annotations

import sys
import threading

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
