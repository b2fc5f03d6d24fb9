"""The writer processes' shared-memory ring (`SinkProcess`, shown with ROS 2's): records round-trip,
a stalled or killed writer never stalls the hand-over and is reported, and the process ends with
its owner."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time

import numpy as np

from wiithrow.app.channels import records
from wiithrow.app.channels.frame_ring import FrameRing
from wiithrow.app.channels.ros2_sink import RING_SLOTS, Ros2ProcessPublisher
from wiithrow.clock import SimClock
from wiithrow.vision.tracked_frame import TrackedFrame
from wiithrow.vision.wiimote.frames import IRFrame
from wiithrow.vision.wiimote.protocol import Button


def _domain() -> int:
    return 100 + os.getpid() % 100


def _tracked(rng: np.random.Generator, n: int = 4) -> TrackedFrame:
    position = rng.normal(size=(n, 3))
    return TrackedFrame(
        float(rng.random()),
        np.arange(n) + 3,
        position,
        np.zeros((n, 3)),
        position.copy(),
        rng.random(n) > 0.5,
        rng.integers(0, 4, n),
    )


#: How long a writer may take to end once told (s): a bound for "it ends", not a speed. It runs
#: `WRITER_NICE` (10) nicer than its owner, so beside four busy loops on the two cores it gets a few
#: percent of a core, and a ROS 2 writer's teardown (its DDS domain) once took more than 10 s there.
END_WITHIN_S = 60.0


def _gone(pid: int, timeout_s: float) -> bool:
    end = time.monotonic() + timeout_s
    while time.monotonic() < end:
        try:
            os.kill(pid, 0)
        except ProcessLookupError:
            return True
        try:  # our own child: reap it
            if os.waitpid(pid, os.WNOHANG)[0] == pid:
                return True
        except ChildProcessError:
            pass
        time.sleep(0.05)
    return False


def test_each_record_comes_back_field_by_field_and_a_ring_behind_counts_its_loss():
    rng = np.random.default_rng(0)
    ring = FrameRing.create(5, records.SLOT_BYTES)
    reader = FrameRing.open(ring.name, 5, records.SLOT_BYTES, ring.wake_fd, other_process=False)
    try:
        dots = np.array([[1.5, 2.0], [np.nan, np.nan], [1000.25, 700.0], [3.0, 4.0]])
        frame = IRFrame(2.5, 2.49, 17, 0x33, dots, np.ones(4), Button(0))
        tracked = _tracked(rng)
        Ps = rng.normal(size=(3, 3, 4))
        records.put_dots(ring, 1, 123, frame)
        records.put_markers(ring, 42, tracked)
        records.put_calibration(ring, Ps, 7.5)
        got = [records.unpack(r) for r in reader.read()]
        records.put_report(ring, 0, 2.25, b"\x33\x00\x01")
        records.put_end(ring, records.PROCESSED, 1)
        got += [records.unpack(r) for r in reader.read()]
        assert isinstance(got[0], records.Dots) and got[0].camera == 1 and got[0].seq == 123
        assert (got[0].frame.t, got[0].frame.t_device, got[0].frame.seq) == (2.5, 2.49, 17)
        np.testing.assert_array_equal(got[0].frame.dots, dots)  # NaN where empty
        assert isinstance(got[1], records.Markers) and got[1].seq == 42
        assert got[1].frame.t == tracked.t
        for name in ("ids", "position", "visible", "n_views"):
            np.testing.assert_array_equal(getattr(got[1].frame, name), getattr(tracked, name))
        assert np.isnan(got[1].frame.velocity).all()  # a ring without vectors does not carry them
        assert isinstance(got[2], records.Calibration) and got[2].t == 7.5
        np.testing.assert_array_equal(got[2].Ps, Ps)
        assert got[3] == records.Report(0, 2.25, b"\x33\x00\x01")
        assert got[4] == records.End(records.PROCESSED, 1, 0.0, 0)
        assert reader.dropped == 0 and reader.read() == []

        for seq in range(10):  # 10 records into 5 slots: the oldest 5 are overwritten, and the
            records.put_markers(ring, seq, tracked)  # next slot is the one a writer may be rewriting
        kept = [records.unpack(r) for r in reader.read()]
        assert [k.seq for k in kept if isinstance(k, records.Markers)] == [6, 7, 8, 9]
        assert reader.dropped == 6 and ring.dropped == 6  # the writer reads it in the header
        records.put_markers(ring, 10, tracked)
        assert [records.unpack(r).seq for r in reader.read()] == [10]  # type: ignore[union-attr]
    finally:
        reader.close()
        ring.close()


def test_a_stalled_writer_process_never_stalls_the_hand_over_and_its_loss_is_told():
    rng = np.random.default_rng(1)
    publisher = Ros2ProcessPublisher(
        _domain(), ["cam0", "cam1"], "link1", clock=SimClock(), namespace=f"/stall_{os.getpid()}"
    )
    pid = publisher.process.pid
    calibrations = [rng.normal(size=(2, 3, 4)) for _ in range(10)]
    handed = RING_SLOTS + 1000
    try:
        os.kill(pid, signal.SIGSTOP)
        # nothing reads: the ring comes round, nothing waits (calibrations: handed over whether a
        # reader wants them or not, the state a later subscriber gets)
        for k in range(handed):
            publisher.publish_calibration(calibrations[k % 10], 0.01 * k)
        assert publisher.ring.written == handed
        os.kill(pid, signal.SIGCONT)
        assert publisher.flush(20.0)
        lost = handed - (RING_SLOTS - 1)  # it read the newest ring-full (but the slot being rewritten)
        assert publisher.records_dropped == lost
        assert publisher.failure is None
        assert f"({lost} frames dropped: the writer process was behind)" in publisher.summary()
    finally:
        os.kill(pid, signal.SIGCONT)
        publisher.close()
    assert _gone(pid, END_WITHIN_S)  # closed by its owner: it ends


def test_a_killed_writer_process_is_one_line_and_the_hand_over_goes_on():
    told: list[str] = []
    publisher = Ros2ProcessPublisher(
        _domain(), ["cam0", "cam1"], "link1", clock=SimClock(), namespace=f"/kill_{os.getpid()}", on_failure=told.append
    )
    try:
        os.kill(publisher.process.pid, signal.SIGKILL)
        end = time.monotonic() + 10.0
        while not told and time.monotonic() < end:
            time.sleep(0.02)
        assert len(told) == 1 and "\n" not in told[0]
        assert told[0].startswith("the ROS 2 writer process ended (exit status -9)")
        tracked = _tracked(np.random.default_rng(2))
        assert [publisher.publish_markers(tracked) for _ in range(100)] == list(range(100))
        publisher.publish_calibration(np.random.default_rng(3).normal(size=(2, 3, 4)))  # handed over regardless
        assert not publisher.flush(0.2)  # nobody reads any more: said, not waited for
        assert "writing stopped: the ROS 2 writer process ended" in publisher.summary()
    finally:
        publisher.close()


def test_the_writer_process_ends_when_its_owner_ends_without_closing_it():
    code = (
        "import os, sys\n"
        "from wiithrow.app.channels.ros2_sink import Ros2ProcessPublisher\n"
        "from wiithrow.clock import SimClock\n"
        f"p = Ros2ProcessPublisher({_domain()}, ['cam0', 'cam1'], 'link1', clock=SimClock(), namespace='/orphan_{os.getpid()}')\n"
        "print(p.process.pid, flush=True)\n"
        "os._exit(0)\n"
    )
    owner = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60)
    assert owner.returncode == 0, owner.stderr
    assert _gone(int(owner.stdout.strip()), END_WITHIN_S)  # its stdin closed with its owner: no orphan


def test_a_writer_process_that_never_started_tells_nothing_later(monkeypatch):
    """A child that ends before READY is refused by the constructor, in one line, and its watcher says
    nothing more: before, a watcher that saw the child end before the constructor gave up waited
    `START_S` (30 s; 2 s here) and then printed "the writer process ended" into whatever ran then (under a load
    of 4 a refused Foxglove port of one test showed up as a second line in the next module's test).
    The constructor's read of READY is slowed here so that the watcher always sees the end first."""
    import pytest

    from wiithrow.app.channels import writer_process
    from wiithrow.app.errors import AppError

    told: list[str] = []
    read_line = writer_process._readline

    def late_readline(stream, timeout_s):
        line = read_line(stream, timeout_s)
        time.sleep(0.5)  # the child has ended and its watcher looked before the constructor gives up
        return line

    monkeypatch.setattr(writer_process, "_readline", late_readline)
    monkeypatch.setattr(writer_process, "START_S", 2.0)  # how long a watcher would wait (30 s)
    ring = FrameRing.create(4, records.SLOT_BYTES)
    start = time.monotonic()
    with pytest.raises(AppError, match="the writer process did not start: not a writer") as refused:
        writer_process.WriterProcess("Test", "tests.helpers.failing_writer", ring, {}, on_failure=told.append)
    assert "\n" not in str(refused.value)
    time.sleep(max(0.0, start + 3.0 - time.monotonic()))  # past START_S: a waiting watcher has spoken
    assert told == []


#: A writer process that commits empty records into the ring named on its command line as fast as
#: it can for the given seconds (its record number in each record's first 8 bytes).
_COMMITTING = """
import struct, sys, time
from wiithrow.app.channels.frame_ring import FrameRing
ring = FrameRing.open(sys.argv[1], int(sys.argv[2]), 8, -1)
print("ready", flush=True)
end = time.monotonic() + float(sys.argv[3])
while time.monotonic() < end:
    for _ in range(1000):
        k, offset = ring.slot()
        struct.pack_into("=Q", ring.buf, offset, k)
        ring.commit()
ring.close()
"""


def test_a_reader_never_sees_the_write_count_go_back_nor_reads_a_record_twice():
    # CPython's struct zeroes what it packs before writing it: a header word stored by pack_into
    # read as 0 for a moment, the reader took that for the write count, went back to record 0 and
    # read the whole ring again (a writer process put 27 s of old frames twice). At this rate the old
    # header showed about 50,000 backward steps a second; each word is now stored whole.
    slots = 64
    ring = FrameRing.create(slots, 8)
    writer = subprocess.Popen(
        [sys.executable, "-c", _COMMITTING, ring.name, str(slots), "0.5"], stdout=subprocess.PIPE, text=True
    )
    try:
        assert writer.stdout is not None and writer.stdout.readline().strip() == "ready"
        last, backward, records_read, repeated, seen_before = 0, 0, 0, 0, -1
        while writer.poll() is None:
            for _ in range(200):
                written = ring.header()[0]
                backward += written < last
                last = written
            for record in ring.read():
                k = int(np.frombuffer(record, dtype=np.uint64)[0])
                repeated += k <= seen_before
                seen_before = max(seen_before, k)
                records_read += 1
        assert writer.wait(10) == 0
    finally:
        if writer.poll() is None:
            writer.kill()
        ring.close()
    assert last > 10_000, f"the writer committed only {last} records: nothing was tested"
    assert records_read > 0
    assert backward == 0, f"the write count went back {backward} times"
    assert repeated == 0, f"{repeated} records read again"
