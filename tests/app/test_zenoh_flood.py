"""A Zenoh flood does not freeze the rig: 10,000 frames a second from another process, each of 16
markers in the rig's view (the costliest frame to check), while the real publisher
(`tests.helpers.steady_publisher`) runs in a third; the `RemoteRig` is polled every 10 ms as the
session's rig loop polls it.

* forged frames (no valid signature, `tests.helpers.rogue_publisher flood:10000`): each poll's
  work stays within one period, the real publisher's frames are followed throughout, the stale
  reason and the stale notice come within 0.1 s of the real publisher stopping (SIGSTOP) during
  the flood, on the arrival clock, and the process's memory returns after it;
* the same flood during a joint-1 alignment on the simulated loopback: the arm is told to brake
  within 100 ms of the publisher's silence being decidable, on the world's clock;
* signed frames (a process of the same user, another stream: what only the bound stops): the
  queue holds at most `MAX_QUEUED_MARKERS` (the oldest dropped, counted and told in the
  refusals' summary), a poll takes at most `MAX_MARKERS_PER_POLL` samples.

What the test cannot decide for the host: a 2-core machine shared with other work wakes a thread
late now and then. The stale reason's and the notice's delays are allowed the machine's own worst
lateness over the flood's seconds (`WakeProbe`, a process of its own), and the figures are printed.
"""

from __future__ import annotations

import gc
import os
import resource
import time

import numpy as np

from tests.app.test_rogue_publishers import (
    REAL_AT,
    Steady,
    _confirm,
    _kept_at,
    _poll_for,
    _poll_until,
    _rig,
    _rogue,
    _sent,
)
from wiithrow.app.cli.bench.publish import free_port
from wiithrow.app.cli.bench.wake_probe import WakeProbe
from wiithrow.app.network.marker_checks import SILENT_S
from wiithrow.app.network.zenoh_session import open_session

#: The rig loop's period (s): each poll's work must fit in it.
PERIOD_S = 0.01
#: How much the process may grow while the flood lasts, and keep after it (MB): the queue's bound
#: (1,000 samples of ~1.5 kB) and Zenoh's buffers, with room for the allocator's arenas.
GROWTH_DURING_MB = 30.0
GROWTH_AFTER_MB = 15.0


def _rss_mb() -> float:
    """This process's resident memory now (MB)."""
    with open(f"/proc/{os.getpid()}/statm") as f:
        return int(f.read().split()[1]) * resource.getpagesize() / 1e6


class RigLoop:
    """Polls the rig every `PERIOD_S` as the session's rig loop does, and measures each poll."""

    def __init__(self, rig) -> None:
        self.rig = rig
        self.wall_s: list[float] = []
        self.cpu_s: list[float] = []
        self.queued: list[int] = []
        self.rss_mb: list[float] = []
        self._next = time.monotonic()
        self._rss_next = self._next

    def tick(self) -> None:
        self.queued.append(self.rig._markers.queued)
        wall, cpu = time.perf_counter(), time.thread_time()
        self.rig.poll()
        self.cpu_s.append(time.thread_time() - cpu)
        self.wall_s.append(time.perf_counter() - wall)
        if time.monotonic() >= self._rss_next:
            self._rss_next += 0.25
            self.rss_mb.append(_rss_mb())
        self._next += PERIOD_S
        time.sleep(max(0.0, self._next - time.monotonic()))
        if self._next < time.monotonic():  # late: the next deadline from now, no catch-up
            self._next = time.monotonic()

    def until(self, condition, timeout_s: float = 30.0) -> bool:
        """Tick until `condition()` holds or `timeout_s` passed; whether it held."""
        end = time.monotonic() + timeout_s
        while not condition():
            if time.monotonic() > end:
                return False
            self.tick()
        return True
        self._rss_next = self._next


def test_a_flood_of_forged_frames_leaves_the_real_source_and_the_stale_reason_on_time(local_meeting):
    subscribe, connect_cfg = local_meeting
    rig, _notices = _rig(subscribe)
    told: list[tuple[float, str]] = []
    rig.notices.subscribe(lambda notice: told.append((time.time(), notice)))
    real = Steady(connect_cfg, 120.0)
    flood = probe = None
    try:
        _confirm(rig, real)
        assert _poll_until(rig, lambda: _kept_at(rig, REAL_AT) >= 50 and rig.stale_reason() is None)
        gc.collect()
        _poll_for(rig, 0.2)
        rss_before = _rss_mb()
        loop = RigLoop(rig)
        probe = WakeProbe()
        probe.begin()
        # 15 s at most (it is ended once measured): a poll that drains whole must end on unchanged code
        flood = _rogue(connect_cfg, "flood:10000", 15.0)
        flood_start = time.monotonic()
        # the flood under way (counts with a deadline: a loaded host is slower, never wrong)
        refused_before = sum(rig.refused.values())
        assert loop.until(lambda: sum(rig.refused.values()) >= refused_before + 5000), rig.refusal_counts()
        pinned = rig.pin.pinned
        assert pinned is not None
        seq_before, flood_before = pinned.seq, sum(rig.refused.values())
        # the real publisher's frames get through it: 50 more followed while the flood went on
        assert loop.until(lambda: rig.pin.pinned is not None and rig.pin.pinned.seq >= seq_before + 50)
        flooded_meanwhile = sum(rig.refused.values()) - flood_before
        assert flood.poll() is None and flooded_meanwhile >= 1000, (
            f"the flood was over ({flood.poll() is not None}) before 50 real frames were followed; "
            f"{flooded_meanwhile} flood frames meanwhile; polls took up to {1e3 * max(loop.cpu_s):.0f} ms of CPU"
        )
        loop.until(lambda: time.monotonic() - flood_start >= 3.0)  # (a few seconds of it, at least)
        real.pause()  # SIGSTOP during the flood
        stale_at = last_fresh = None

        def stale_seen() -> bool:
            nonlocal stale_at, last_fresh
            if stale_at is None and rig.stale_reason() is not None:
                stale_at, last_fresh = time.time(), rig._last_fresh_arrival
            return stale_at is not None and any("are stale" in n for _, n in told)

        assert loop.until(stale_seen), "the markers did not turn stale"
        loop.until(lambda: False, 0.2)  # the flood goes on after it
        flood.terminate()
        machine = probe.end()
        flood_sent = _sent(flood)
        flood_s = time.monotonic() - flood_start
        real.resume()
        kept = _kept_at(rig, REAL_AT)
        assert _poll_until(rig, lambda: _kept_at(rig, REAL_AT) >= kept + 20), rig.refusal_counts()  # not locked out
        gc.collect()
        _poll_for(rig, 0.5)
        rss_after = _rss_mb()
    finally:
        if probe is not None:
            probe.close()
        if flood is not None and flood.poll() is None:
            flood.kill()
        real.kill()
    rig.close()
    delivered = rig.refused["unauthenticated"]
    stale_notices = [t for t, n in told if "are stale" in n and t >= (last_fresh or 0.0)]
    late_s = machine["max_ms"] / 1e3
    print(
        f"flood: {flood_sent} frames sent in {flood_s:.1f} s, {delivered} delivered and refused; polls: "
        f"{len(loop.cpu_s)}, CPU max {1e3 * max(loop.cpu_s):.2f} ms, wall p99 "
        f"{1e3 * sorted(loop.wall_s)[int(0.99 * len(loop.wall_s))]:.2f} ms max {1e3 * max(loop.wall_s):.2f} ms; "
        f"queue max {max(loop.queued)}; 50 real frames followed while {flooded_meanwhile} forged ones came; "
        f"RSS before {rss_before:.1f} MB, during max {max(loop.rss_mb):.1f} MB, after {rss_after:.1f} MB; "
        f"machine wake max {machine['max_ms']:.1f} ms"
    )
    # each poll's work fits in one period: the rig's lock is never held beyond it for the flood
    assert max(loop.cpu_s) <= PERIOD_S, f"a poll's work took {1e3 * max(loop.cpu_s):.1f} ms of CPU"
    # its wall time is the host's too: a poll preempted by other processes holds the lock longer
    # without doing more (4 test workers on 2 cores): said, not judged (the CPU above is the work)
    worst = int(np.argmax(loop.wall_s))
    if loop.wall_s[worst] > PERIOD_S + late_s:
        print(
            f"the host was late: a poll held the lock {1e3 * loop.wall_s[worst]:.1f} ms for "
            f"{1e3 * loop.cpu_s[worst]:.2f} ms of CPU (the machine woke up to {1e3 * late_s:.1f} ms late)"
        )
    assert stale_at is not None and last_fresh is not None, "the markers never turned stale"
    decidable = last_fresh + SILENT_S
    print(f"stale reason {1e3 * (stale_at - decidable):.0f} ms after it was decidable")
    assert stale_at - decidable <= 0.1 + late_s
    assert stale_notices, told
    print(f"stale notice {1e3 * (stale_notices[0] - decidable):.0f} ms after it was decidable")
    assert stale_notices[0] - decidable <= 0.1 + late_s
    assert max(loop.rss_mb) - rss_before <= GROWTH_DURING_MB and rss_after - rss_before <= GROWTH_AFTER_MB
    assert max(loop.queued) <= rig._markers.max_queued
    assert 0 < delivered <= flood_sent and rig._pinned_failure is None


def test_a_flood_of_signed_frames_is_bounded_by_the_queue_and_each_poll(local_meeting):
    from wiithrow.app.network.remote_rig import MAX_MARKERS_PER_POLL, MAX_QUEUED_MARKERS

    subscribe, connect_cfg = local_meeting
    rig, notices = _rig(subscribe)
    real = Steady(connect_cfg, 120.0)
    flood = None
    try:
        _confirm(rig, real)
        assert _poll_until(rig, lambda: _kept_at(rig, REAL_AT) >= 20)
        gc.collect()
        rss_before = _rss_mb()
        flood = _rogue(connect_cfg, "flood:10000", 3.0, signed=True)
        # nobody polls for a while (an operation holds the rig): the queue fills, the oldest go
        end = time.monotonic() + 20.0
        while rig._markers.dropped < 100 and time.monotonic() < end:
            time.sleep(0.05)
        queued_unpolled = rig._markers.queued
        loop = RigLoop(rig)
        taken: list[int] = []
        while flood.poll() is None:
            loop.tick()
            taken.append(rig.last_poll_taken)
        flood_sent = _sent(flood)
        assert _poll_until(rig, lambda: rig._markers.queued == 0)
        assert _poll_until(rig, lambda: any("queue_full" in n for n in notices), 15.0), notices
        gc.collect()
        _poll_for(rig, 0.5)
        rss_after = _rss_mb()
    finally:
        if flood is not None and flood.poll() is None:
            flood.kill()
        real.kill()
    rig.close()
    dropped = rig.refused["queue_full"]
    print(
        f"signed flood: {flood_sent} sent; {dropped} dropped from the full queue; queue unpolled {queued_unpolled}; "
        f"taken per poll max {max(taken)}; CPU per poll max {1e3 * max(loop.cpu_s):.2f} ms; "
        f"RSS before {rss_before:.1f} MB, during max {max(loop.rss_mb):.1f}, after {rss_after:.1f} MB"
    )
    assert queued_unpolled <= MAX_QUEUED_MARKERS and max(loop.queued) <= MAX_QUEUED_MARKERS
    assert dropped >= 100 and dropped == rig._markers.dropped
    assert max(taken) <= MAX_MARKERS_PER_POLL and max(loop.cpu_s) <= PERIOD_S
    summary = next(n for n in notices if "queue_full" in n)
    assert "dropped" in summary
    assert max(loop.rss_mb) - rss_before <= GROWTH_DURING_MB and rss_after - rss_before <= GROWTH_AFTER_MB
    assert _kept_at(rig, (2.0, -0.3, 0.3)) == 0  # the flood's stream was never followed


def test_the_stale_data_brake_comes_within_100_ms_under_a_flood(tmp_path):
    """The joint-1 alignment on markers that crossed Zenoh (the simulated loopback, on the world's
    clock) while a forged flood of 10,000 frames a second comes from another process: the publisher
    stops mid-turn and the arm is told to brake within 100 ms of the silence being decidable, as
    without the flood (`test_marker_checks`)."""
    from wiithrow.app.cli.bench.publish import loopback_configs
    from wiithrow.app.rig.waiting import pump
    from wiithrow.app.session import Session, demo_target_base
    from wiithrow.app.worlds import SimWorld
    from wiithrow.app.worlds.remote import simulated_loopback

    listen_cfg, connect_cfg = loopback_configs(tmp_path, free_port())
    subscribe, publish = open_session(listen_cfg), open_session(connect_cfg)
    world = SimWorld(seed=0, markers=simulated_loopback(publish, subscribe, "lab"))
    session = Session(world, rng=np.random.default_rng(1))
    rig = world.rig
    assert rig.source is not None
    publish_frames = rig.source
    stops: list[float] = []
    arm_stop = world.arm.stop

    def stop() -> None:
        stops.append(world.clock.now())
        arm_stop()

    world.arm.stop = stop  # type: ignore[method-assign]
    flood = None
    try:
        world.connect()
        pump(world.clock, rig, 0.2, step_s=0.001)
        flood = _rogue(connect_cfg, "flood:10000", 120.0)
        end = time.monotonic() + 30.0
        while rig.refused["unauthenticated"] < 2000 and time.monotonic() < end:  # the flood is under way
            pump(world.clock, rig, 0.01, step_s=0.001)
        flooded = rig.refused["unauthenticated"]
        session.set_target(demo_target_base(azimuth=0.6))  # far: joint 1 is still turning when it stops
        t_cut = world.clock.now() + 0.6
        rig.source = lambda: publish_frames() if world.clock.now() < t_cut else 0  # the publisher stops
        alignment = session.align()
        last_fresh = rig._last_fresh_arrival
        during = rig.refused["unauthenticated"] - flooded
        flood_sent = _sent(flood)
    finally:
        if flood is not None and flood.poll() is None:
            flood.kill()
        session.close()
        publish.close()
        subscribe.close()
    assert flooded >= 2000 and during > 0, (flooded, during)  # the flood went on during the alignment
    assert alignment.status == "stale" and "no fresh marker frame from wiithrow/lab for" in alignment.message
    assert last_fresh is not None and stops
    decidable = last_fresh + SILENT_S
    print(
        f"under a flood ({flood_sent} sent, {during} during the alignment): braked {1e3 * (stops[0] - decidable):.0f} ms after the silence was decidable"
    )
    assert 0.0 <= stops[0] - decidable <= 0.1
