"""The threads' loops go on after a fault, and say it once: the rig loop whose busy check raises,
the Foxglove relay whose handler raises, and `FaultLines`' limit on distinct lines."""

from __future__ import annotations

import threading
import time
from types import SimpleNamespace

from wiithrow.app.foxglove.live import _Relay
from wiithrow.app.session.rig_loop import READ_FAILED, RigLoop
from wiithrow.fault_lines import MAX_DISTINCT_FAULTS, FaultLines


def _wait(condition, timeout_s: float = 30.0) -> bool:
    end = time.monotonic() + timeout_s
    while not condition():
        if time.monotonic() > end:
            return False
        time.sleep(0.005)
    return True


def test_the_rig_loop_goes_on_when_its_busy_check_raises():
    calls = {"busy": 0, "polls": 0}

    def busy() -> bool:
        calls["busy"] += 1
        if calls["busy"] <= 5:
            raise RuntimeError("the session's state is unreadable")
        return False

    rig = SimpleNamespace(poll=lambda: calls.__setitem__("polls", calls["polls"] + 1))
    world = SimpleNamespace(rig=rig, clock=SimpleNamespace(sleep=lambda s: time.sleep(0.001)))
    told: list[str] = []
    cleared: list[str] = []
    loop = RigLoop(world, busy=busy, tell=told.append, clear_message=cleared.append)  # type: ignore[arg-type]
    loop.start()
    try:
        assert _wait(lambda: calls["polls"] >= 10), calls
    finally:
        loop.stop()
    assert told == [READ_FAILED + "the session's state is unreadable"]  # five faults, told once
    assert cleared == told  # and taken back once polls succeed


def test_the_foxglove_relay_goes_on_after_its_handler_raises(capfd):
    handled: list[int] = []

    def handle(event) -> None:
        if event % 2:
            raise ValueError("an odd event")
        handled.append(event)

    relay = _Relay(handle, lambda: True, thread=True)
    for event in range(10):
        relay.put(event)  # type: ignore[arg-type]
    relay.stop()
    assert handled == [0, 2, 4, 6, 8]
    err = capfd.readouterr().err
    assert err.splitlines() == ["wiithrow Foxglove relay: ValueError: an odd event (the relay goes on)"], err


def test_fault_lines_print_each_kind_once_and_stop_at_the_limit(capfd):
    faults = FaultLines("loop")
    for i in range(3 * MAX_DISTINCT_FAULTS):
        for _ in range(5):
            faults.report(RuntimeError(f"fault {i}"))
    lines = capfd.readouterr().err.splitlines()
    assert faults.count == 15 * MAX_DISTINCT_FAULTS
    assert lines[:MAX_DISTINCT_FAULTS] == [f"wiithrow loop: RuntimeError: fault {i} (it goes on)" for i in range(10)]
    assert lines[MAX_DISTINCT_FAULTS:] == [
        f"wiithrow loop: more faults than {MAX_DISTINCT_FAULTS} kinds: counted, not shown"
    ]
    assert faults.last == f"RuntimeError: fault {3 * MAX_DISTINCT_FAULTS - 1}"
    threading.Thread(target=faults.report, args=(KeyError("k"),)).start()  # from any thread
    assert _wait(lambda: faults.count == 15 * MAX_DISTINCT_FAULTS + 1)
