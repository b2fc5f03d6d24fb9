"""`wiithrow bench latency`: from a remote's HID report being read to its 3D marker at each consumer.

The demo's system in real time (`simulated_session`: the kinematic world on the system clock, its
true calibration, the demo's target lit): two byte-exact simulated remotes (`SimulatedWiimote`)
write HID reports at 100 Hz, each read by the real driver (`WiimoteDriver`: link, `ReportDecoder`)
in the session's rig loop (`Session.start`, a poll every 10 ms), synchronised and tracked by the
local rig (`RigStream`), which stamps every tracked frame's stages on the one clock
(`wiithrow.app.rig.stage_stamps`). Consumers, wired as `serve` and `demo --publish --record`
wire them and in the order they listen to the rig:

* `publisher`: what `--publish` runs (`publish_session` subscribes it before the dashboard
  starts): a `ZenohProcessPublisher`, each frame packed on the rig's thread into the shared-memory
  ring of a writer process that owns a Zenoh session on this host's loopback and puts it; stamped
  when the child's put of the frame returned, on CLOCK_MONOTONIC (`time.monotonic_ns` in the
  child: the system-wide clock the rig's `SystemClock` reads), handed back in a small ring and
  collected here every `COLLECT_S` (`put_stamps`);
* `recorder` (when attached): a `SessionRecorder` (what `--record` starts: the rig, the arm's
  joints at 50 Hz, the throws) writing an MCAP file in a temporary folder; stamped when its
  listener has written the frame's messages;
* `session`: the end of the poll that tracked the frame (its `Flushed` event), when the rig's
  lock is released and `tracked_since` (the session, the alignment, a throw) can read it;
* `dashboard` (when attached): a `Dashboard` with no browser connected, its refresh thread at up
  to 20 Hz, each refresh 3 ms after a poll of the rig ended (`wiithrow.web.poll_phase`); stamped
  when a refresh that drew the frame returned (the rig's newest frame in the refresh's
  `rig_reading`). A polled consumer: only the frames a refresh drew are stamped (one in five).

The writer process is woken once per poll of the rig, when the poll is over
(`wiithrow.listeners.batch`, `FrameRing.wake`), not in the middle of it, where it took the rig
thread's core. With the dashboard attached the process runs as `serve` and `demo` run it: the refresh never waits
for the rig's lock (`wiithrow.web.live.read_rig`) and the interpreter's switch interval is 0.5 ms
while the dashboard serves (`wiithrow.web.throttle.SwitchInterval`), so that a thread woken by a
tracked frame while the refresh draws gets the interpreter within about half a millisecond instead
of Python's 5 ms. The publisher needs no thread of this process (on one, woken by each frame, it would wait for
the interpreter behind the rig's thread and the refresh): the JSON and the put, which with congestion
control BLOCK waits when a subscriber (or anything else on the session's link) is slow, run on the
writer process's interpreter (`wiithrow.app.channels.zenoh_sink`), and the rig's thread
never waits for it.

Every latency is from `read` (when the driver's link read the report that completed the frame).
What comes before it is not measured: the wait in the HID buffer for the rig loop's next poll
(up to its 10 ms period), the Bluetooth link and the camera's own frame (docs/performance.md).

Figures, per configuration (`bare`: publisher and session; `dashboard_recorder`: all four):
`stages` (decoded, synced, tracked: ms after the read) and `consumers`, each with `count`,
`p50_ms`, `p99_ms`, `max_ms`, over `seconds` (60 by default, `--seconds`) after a warm-up (the
first 50 frames tracked, then 1 s);
`report_to_consumer_p99_ms`, the worst consumer p99 but the dashboard's (goal <= 1 ms with the
dashboard and the recorder attached: `meets_goal`); `deliveries_without_stamps` (frames a
consumer got that the pipeline did not stamp: those a flush tracked, when a camera's report came
late, and the stamps of which have no report that completed them); `publisher_stamps_repeated`
(a frame's put stamped twice by the writer process, not counted again: 0 unless something is
wrong); `machine_wake`: how late the machine woke a thread that asked to run, over the same
seconds (`wake_probe`: cyclictest's method in a process of its own, a deadline every millisecond;
count, p50, p99, max in ms), the floor under every figure above: on a virtual machine a consumer's
p99 cannot be told from the host's scheduling when this p99 is near it; `gc_pauses`: the garbage
collector's passes over the same seconds, per generation (count, p50, max, total ms: a pass holds
the whole process); the machine's load average. Both configurations run with the start-up's
objects frozen out of the collector's passes, as `serve` and `demo` serve
(`wiithrow.app.cli.heap.frozen_heap`).
"""

from __future__ import annotations

import os
import tempfile
import threading
import time
from pathlib import Path
from typing import Any

import numpy as np

from wiithrow.app.channels.zenoh_sink import ZenohProcessPublisher
from wiithrow.app.cli.bench.wake_probe import WakeProbe
from wiithrow.app.cli.heap import CollectionPauses, frozen_heap
from wiithrow.app.errors import AppError
from wiithrow.app.recording.session import SessionRecorder
from wiithrow.app.rig.events import Flushed, FramesProcessed, RigEvent
from wiithrow.app.rig.pipeline import TrackingPipeline
from wiithrow.app.rig.stage_stamps import StageStamps
from wiithrow.app.session import Session, demo_target_base, simulated_session
from wiithrow.clock import SystemClock
from wiithrow.vision.tracked_frame import TrackedFrame
from wiithrow.web.server import Dashboard

#: Host-side goal: report read -> every event-driven consumer, p99 (ms).
GOAL_P99_MS = 1.0
#: Seconds run before measuring, once the rig has tracked `WARM_UP_FRAMES` frames (the tracks settle).
WARM_UP_S = 1.0
#: Frames the rig must have tracked before the warm-up's seconds count: on a fresh install the first
#: poll compiles the numba kernels (11 s on a 2-core machine), and a run measured from a fixed start
#: measured one frame of 11 s; `WARM_UP_LIMIT_S` bounds the wait (a rig that tracks nothing).
WARM_UP_FRAMES = 50
WARM_UP_LIMIT_S = 180.0
RIG_NAME = "bench-latency"
#: How often the publisher's put stamps are collected from its writer process (s): a wake of this
#: process's interpreter five times a second, well within the 1,000 frames the stamps keep.
COLLECT_S = 0.2


def summary(seconds_list: list[float]) -> dict[str, float | int]:
    """count, p50, p99 and max of latencies given in seconds, in ms."""
    if not seconds_list:
        return {"count": 0, "p50_ms": float("nan"), "p99_ms": float("nan"), "max_ms": float("nan")}
    ms = 1e3 * np.asarray(seconds_list)
    return {
        "count": len(ms),
        "p50_ms": float(np.percentile(ms, 50)),
        "p99_ms": float(np.percentile(ms, 99)),
        "max_ms": float(ms.max()),
    }


class _SessionReads:
    """Stamps `session`: the frames a poll tracked, when that poll ends (its `Flushed` event)."""

    def __init__(self, stamps: StageStamps) -> None:
        self.stamps = stamps
        self._pending: list[TrackedFrame] = []

    def __call__(self, event: RigEvent) -> None:
        if isinstance(event, FramesProcessed):
            self._pending.extend(event.tracked)
        elif isinstance(event, Flushed):
            now = self.stamps.clock.now()
            for frame in [*self._pending, *event.tracked]:
                self.stamps.delivered("session", frame.t, now)
            self._pending = []


def _stamp_recorder(stamps: StageStamps, event: RigEvent) -> None:
    """Listens right after the recorder: its listener has written what the event brought."""
    if isinstance(event, FramesProcessed | Flushed) and event.tracked:
        now = stamps.clock.now()
        for frame in event.tracked:
            stamps.delivered("recorder", frame.t, now)


class _PutStamps:
    """Stamps `publisher`: each frame when the writer process's put returned (its `put_stamps`,
    collected by a thread every `COLLECT_S`, and by `collect()`)."""

    def __init__(self, stamps: StageStamps, publisher: ZenohProcessPublisher) -> None:
        self.stamps = stamps
        self.publisher = publisher
        self.lock = threading.RLock()  # (held around a collect and the restart)
        self.since = float("-inf")
        self._seen: set[float] = set()
        self.repeated = 0
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, name="wiithrow-bench-put-stamps", daemon=True)
        self._thread.start()

    def collect(self) -> None:
        with self.lock:
            for t, at in self.publisher.put_stamps():
                row = self.stamps.stages(t)
                if row is not None and row[0] < self.since:  # read before `restart`: the warm-up's
                    continue
                if t in self._seen:  # (a frame is put once: a second stamp would be a fault, counted)
                    self.repeated += 1
                    continue
                self._seen.add(t)
                self.stamps.delivered("publisher", t, at)

    def restart(self) -> None:
        """Collect what was put so far, then forget the latencies (`StageStamps.restart`); a frame
        read before now whose put comes later is not counted either (the others deliver at once)."""
        with self.lock:
            self.collect()
            self.stamps.restart()
            self.since = self.stamps.clock.now()
            self._seen.clear()
            self.repeated = 0

    def _run(self) -> None:
        while not self._stop.wait(COLLECT_S):
            self.collect()

    def stop(self) -> None:
        """Collect the last stamps (after the child has put every frame handed over) and end."""
        self._stop.set()
        self._thread.join(timeout=2.0)
        self.publisher.flush(2.0)
        self.collect()


class _StampedDashboard(Dashboard):
    """The dashboard, stamping a frame when the first refresh that read it (the rig's newest) returned."""

    stamps: StageStamps
    _seen_t = float("nan")

    def refresh(self) -> None:
        super().refresh()
        newest = self.rig_reading.tracked if self.rig_reading is not None else None
        if newest is not None and newest.t != self._seen_t:
            self._seen_t = newest.t
            self.stamps.delivered("dashboard", newest.t)


#: The consumers, in the order they listen; without the dashboard and the recorder, only these:
CONSUMERS = ("publisher", "recorder", "session", "dashboard")
BARE = ("publisher", "session")


def _warm_up(stamps: StageStamps) -> None:
    """Until the rig has tracked `WARM_UP_FRAMES` frames (at most `WARM_UP_LIMIT_S`), then `WARM_UP_S`."""
    deadline = time.monotonic() + WARM_UP_LIMIT_S
    while stamps.frames_stamped < WARM_UP_FRAMES:
        if time.monotonic() > deadline:
            raise AppError(
                f"bench latency: the rig tracked {stamps.frames_stamped} frames in {WARM_UP_LIMIT_S:.0f} s "
                f"(the simulated remotes report at 100 Hz): nothing to measure"
            )
        time.sleep(0.05)
    time.sleep(WARM_UP_S)


def measure(seconds: float, *, attached: bool) -> dict[str, Any]:
    """One configuration: with the dashboard and the recorder attached (`attached`), or without."""
    session: Session = simulated_session(seed=0, calibration="true", realtime=True, quiet=True)
    world = session.world
    rig = world.rig
    if not isinstance(rig, TrackingPipeline):
        raise TypeError(f"bench latency needs the local rig, not {type(rig).__name__}")
    session.set_target(demo_target_base())
    if not isinstance(world.clock, SystemClock):  # the writer process stamps its puts on CLOCK_MONOTONIC
        raise TypeError(f"bench latency needs the system clock, not {type(world.clock).__name__}")
    stamps = StageStamps(world.clock)
    publisher = ZenohProcessPublisher(RIG_NAME, rig.camera_names, "link1", clock=world.clock, stamp_puts=True)
    put_stamps = _PutStamps(stamps, publisher)
    dashboard: Dashboard | None = None
    recorder: SessionRecorder | None = None
    pauses = CollectionPauses()
    probe = WakeProbe()  # (started now: ready long before the warm-up ends; closed in the `finally`)
    with tempfile.TemporaryDirectory(prefix="wiithrow-bench-latency-") as folder:
        try:
            if attached:  # (it does not listen to the rig: built first, out of the rig's lock)
                dashboard = _StampedDashboard(session, port=0)
                dashboard.stamps = stamps
            with rig.lock:  # between two polls: every consumer sees the same frames
                rig.stamps = stamps
                publisher.follow(rig)  # as `publish_session` does, before `run_dashboard`
                if attached:  # as `run_dashboard(record=...)` does
                    recorder = SessionRecorder(session, Path(folder) / "run.mcap")
                    recorder.begin()
                    rig.subscribe(lambda event: _stamp_recorder(stamps, event))
                rig.subscribe(_SessionReads(stamps))
            with frozen_heap():  # as `run_dashboard` serves (`wiithrow.app.cli.heap`)
                if dashboard is not None:
                    dashboard.start()  # starts the session's rig loop too
                else:
                    session.start()
                _warm_up(stamps)
                put_stamps.restart()  # (stamps.restart(), the warm-up's puts collected and forgotten first)
                probe.begin()
                pauses.begin()
                time.sleep(seconds)
                gc_pauses = pauses.end()
                machine_wake = probe.end()
            with rig.lock:
                rig.stamps = None
        finally:
            probe.close()
            session.stop()
            if dashboard is not None:
                dashboard.close()
            if recorder is not None:
                recorder.close()
            session.close()
            put_stamps.stop()
            publisher.close()
    names = CONSUMERS if attached else BARE
    consumers = {name: summary(stamps.delivered_after.get(name, [])) for name in names}
    return {
        "stages": {stage: summary(values) for stage, values in stamps.since_read.items()},
        "consumers": consumers,
        "report_to_consumer_p99_ms": max(float(c["p99_ms"]) for name, c in consumers.items() if name != "dashboard"),
        "deliveries_without_stamps": stamps.unknown_deliveries,
        "publisher_stamps_repeated": put_stamps.repeated,
        "machine_wake": machine_wake,
        "gc_pauses": gc_pauses,
    }


def run(quick: bool = False, seconds: float | None = None) -> dict[str, Any]:
    duration = seconds if seconds is not None else (3.0 if quick else 60.0)
    bare = measure(duration, attached=False)
    attached = measure(duration, attached=True)
    worst = attached["report_to_consumer_p99_ms"]
    return {
        "remotes": 2,
        "report_rate_hz": 100,
        "seconds": duration,
        "bare": bare,
        "dashboard_recorder": attached,
        "goal_p99_ms": GOAL_P99_MS,
        "meets_goal": bool(worst <= GOAL_P99_MS),
        "load_average_1min": os.getloadavg()[0],
    }
