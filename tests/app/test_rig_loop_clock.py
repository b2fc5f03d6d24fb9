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
