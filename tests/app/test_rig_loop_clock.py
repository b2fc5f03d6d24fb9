"""The session's rig loop on a simulated clock (what the hardware path's tests run on): it lets time
pass only while no operation runs, so that an operation's own waits are the only ones moving the
clock meanwhile."""

from __future__ import annotations

import threading
import time
from types import SimpleNamespace

from wiithrow.app.session.rig_loop import RigLoop
from wiithrow.clock import SimClock


class CountingRig:
    def __init__(self) -> None:
        self.polls = 0

    def poll(self) -> None:
        self.polls += 1


def test_a_simulated_clock_moves_only_while_no_operation_runs():
    clock, rig = SimClock(), CountingRig()
    busy = threading.Event()
    busy.set()
    loop = RigLoop(SimpleNamespace(clock=clock, rig=rig), busy=busy.is_set, tell=print, clear_message=print)  # type: ignore[arg-type]
    loop.start()
    try:
        time.sleep(0.2)  # an operation runs: whatever the host does meanwhile, the loop moves nothing
        assert clock.now() == 0.0 and rig.polls == 0
        busy.clear()
        deadline = time.monotonic() + 30.0
        while clock.now() < 1.0 and time.monotonic() < deadline:  # idle: time passes, the rig is read
            time.sleep(0.001)
        assert clock.now() >= 1.0 and rig.polls >= 100
        busy.set()
        for _ in range(600):  # a read under way when the operation began ends (a loaded host: later)
            before = clock.now()
            time.sleep(0.05)
            if clock.now() == before:
                break
        frozen = clock.now()
        time.sleep(0.2)
        assert clock.now() == frozen
    finally:
        loop.stop()


def test_a_paused_session_loop_moves_no_time_and_resumes_after():
    """`Session.rig_loop_paused`: a computation between operations (train's model-mismatch fit)
    runs while the idle loop neither reads nor lets simulated time pass; then it goes on."""
    from wiithrow.app.session.session import Session

    clock, rig = SimClock(), CountingRig()
    session = SimpleNamespace(
        _loop=RigLoop(SimpleNamespace(clock=clock, rig=rig), busy=lambda: False, tell=print, clear_message=print)
    )  # type: ignore[arg-type]
    session._loop.start()
    try:
        deadline = time.monotonic() + 30.0
        while clock.now() < 0.5 and time.monotonic() < deadline:  # idle: time passes
            time.sleep(0.001)
        with Session.rig_loop_paused(session):  # type: ignore[arg-type]
            frozen, polls = clock.now(), rig.polls
            time.sleep(0.2)
            assert clock.now() == frozen and rig.polls == polls, "the paused loop moved time or read the rig"
        deadline = time.monotonic() + 30.0
        while clock.now() < frozen + 0.5 and time.monotonic() < deadline:
            time.sleep(0.001)
        assert clock.now() >= frozen + 0.5, "the loop did not go on after the pause"
    finally:
        session._loop.stop()
