"""A batch of events (`wiithrow.listeners.batch`): what listeners defer with `after_batch` runs once
per key when the outermost batch of its thread ends, and a marker source's poll is one batch that
ends after the source let go of its lock (the writer processes' rings are woken there:
`FrameRing.wake`)."""

from __future__ import annotations

import logging
import select
import threading

import pytest

from wiithrow.app.channels.frame_ring import FrameRing
from wiithrow.app.session import simulated_session
from wiithrow.listeners import after_batch, batch


def test_each_key_runs_once_when_the_outermost_batch_ends():
    ran: list[str] = []
    with batch():
        assert after_batch("a", lambda: ran.append("a1"))
        with batch():  # nested: the outer one runs them
            assert after_batch("b", lambda: ran.append("b"))
            assert after_batch("a", lambda: ran.append("a2"))  # replaces a1
        assert ran == []
    assert ran == ["a2", "b"]
    ran.clear()
    with batch():
        pass
    assert ran == []  # nothing left over from the batch before


def test_outside_a_batch_nothing_is_deferred():
    ran: list[int] = []
    assert not after_batch("a", lambda: ran.append(1))
    assert ran == []  # the caller acts itself


def test_a_failing_action_is_logged_and_the_others_still_run(caplog):
    ran: list[str] = []

    def fail() -> None:
        raise RuntimeError("broken action")

    with caplog.at_level(logging.ERROR, logger="wiithrow.listeners"), batch():
        after_batch("fails", fail)
        after_batch("runs", lambda: ran.append("runs"))
    assert ran == ["runs"]
    assert "an action at the end of a batch of events failed" in caplog.text and "broken action" in caplog.text


def test_another_threads_batch_defers_nothing_of_this_thread():
    ran: list[str] = []
    inside, leave = threading.Event(), threading.Event()

    def other() -> None:
        with batch():
            inside.set()
            leave.wait(5.0)

    thread = threading.Thread(target=other)
    thread.start()
    assert inside.wait(5.0)
    assert not after_batch("mine", lambda: ran.append("mine"))  # this thread has no batch open
    leave.set()
    thread.join(5.0)
    assert ran == []


def _readable(fd: int) -> bool:
    return fd in select.select([fd], [], [], 0.0)[0]


def test_a_ring_woken_in_a_batch_wakes_its_reader_once_when_the_batch_ends():
    writer = FrameRing.create(8, 16)
    reader = FrameRing.open(writer.memory.name, 8, 16, writer.wake_fd, other_process=False)
    try:
        assert reader.wait(0.0) == []  # the reader went to sleep (and woke at its timeout)
        with batch():
            for _ in range(3):
                k, offset = writer.slot()
                writer.buf[offset : offset + 8] = k.to_bytes(8, "little")
                writer.commit()
                writer.wake()
            assert not _readable(writer.wake_fd)  # not yet: the batch is open
        assert _readable(writer.wake_fd)
        assert len(reader.read()) == 3
        reader.acknowledge()
        reader.wait(0.0)  # takes the wake, and sleeps again
        assert not _readable(writer.wake_fd)
        with batch():  # more than half the ring unread: woken at once, in the batch
            for _ in range(5):
                k, offset = writer.slot()
                writer.buf[offset : offset + 8] = k.to_bytes(8, "little")
                writer.commit()
                writer.wake()
                assert _readable(writer.wake_fd) == (writer.written - 3 > 4)  # (8 slots)
        assert len(reader.read()) == 5
        reader.acknowledge()
        reader.wait(0.0)
        with batch():  # a ring closed before its deferred wake: nothing happens, nothing raises
            writer.wake()
            writer.close()
    finally:
        reader.close()
        writer.close()


@pytest.fixture(scope="module")
def session():
    session = simulated_session(seed=5, calibration="true", quiet=True)
    yield session
    session.close()


def test_a_rigs_poll_is_one_batch_that_ends_after_the_rig_let_go_of_its_lock(session):
    rig = session.world.rig
    free_at_end: list[bool] = []

    def lock_is_free() -> bool:  # asked from another thread: the rig's lock is re-entrant
        got: list[bool] = []

        def attempt() -> None:
            got.append(rig.lock.acquire(blocking=False))
            if got[0]:
                rig.lock.release()

        thread = threading.Thread(target=attempt)
        thread.start()
        thread.join(5.0)
        return got == [True]

    events = 0

    def listener(event: object) -> None:
        nonlocal events
        events += 1
        after_batch(listener, lambda: free_at_end.append(lock_is_free()))

    unsubscribe = rig.subscribe(listener)
    try:
        for _ in range(5):
            session.world.clock.sleep(0.01)
            rig.poll()
    finally:
        unsubscribe()
    assert events >= 5 * 3  # each poll told it of both cameras' frames and of the flush (at least)
    assert free_at_end == [True] * 5  # once per poll, after the poll released the lock
