"""`wiithrow bench latency`: from a remote's HID report being read to its 3D marker at each consumer.

The demo's system in real time (`simulated_session`: the kinematic world on the system clock, its
true calibration, the demo's target lit): two byte-exact simulated remotes (`SimulatedWiimote`)
write HID reports at 100 Hz, each read by the real driver (`WiimoteDriver`: link, `ReportDecoder`)
in the session's rig loop (`Session.start`, a poll every 10 ms), synchronised and tracked by the
local rig (`RigStream`), which stamps every tracked frame's stages on the one clock
(`wiithrow.app.rig.stage_stamps`). Consumers, wired as `serve` and `demo --publish --record`
wire them and in the order they listen to the rig:

* `publisher`: a `RigFollower` over a Zenoh session on this host's loopback (`publish_session`
  subscribes it before the dashboard starts); stamped when its thread's put of the frame returned;
* `recorder` (when attached): a `SessionRecorder` (what `--record` starts: the rig, the arm's
  joints at 50 Hz, the throws) writing an MCAP file in a temporary folder; stamped when its
  listener has written the frame's messages;
* `session`: the end of the poll that tracked the frame (its `Flushed` event), when the rig's
  lock is released and `tracked_since` (the session, the alignment, a throw) can read it;
* `dashboard` (when attached): a `Dashboard` with no browser connected, its refresh thread at up
  to 20 Hz; stamped when a refresh that drew the frame returned (the rig's newest frame in the
  refresh's `rig_reading`). A polled consumer: its figure is mostly how long the frame waited for
  the next refresh, not host processing.

With the dashboard attached the process runs as `serve` and `demo` run it: the refresh never waits
for the rig's lock (`wiithrow.web.live.read_rig`) and the interpreter's switch interval is 0.5 ms
while the dashboard serves (`wiithrow.web.throttle.SwitchInterval`), so that the publisher's
thread, woken by a tracked frame while the refresh draws, gets the interpreter within about half
a millisecond instead of Python's 5 ms. The publisher's put stays on its own thread: a Zenoh put
with congestion control BLOCK waits when a subscriber (or anything else on the session's link)
is slow, and the rig's thread must never wait for one.

Every latency is from `read` (when the driver's link read the report that completed the frame).
What comes before it is not measured: the wait in the HID buffer for the rig loop's next poll
(up to its 10 ms period), the Bluetooth link and the camera's own frame (README, "Latency").

Figures, per configuration (`bare`: publisher and session; `dashboard_recorder`: all four):
`stages` (decoded, synced, tracked: ms after the read) and `consumers`, each with `count`,
`p50_ms`, `p99_ms`, `max_ms`, over `seconds` (60 by default, `--seconds`) after a 1 s warm-up;
`report_to_consumer_p99_ms`, the worst consumer p99 but the dashboard's (goal <= 1 ms with the
dashboard and the recorder attached: `meets_goal`); `deliveries_without_stamps` (frames a
consumer got that the pipeline did not stamp: those a flush tracked, when a camera's report came
late, and the stamps of which have no report that completed them); the machine's load average.
"""

from __future__ import annotations

import os
import tempfile
import time
from pathlib import Path
from typing import Any

import numpy as np

from wiithrow.app.network.publisher import RigFollower, RigPublisher
from wiithrow.app.network.zenoh_session import open_session
from wiithrow.app.recording.session import SessionRecorder
from wiithrow.app.rig.events import Flushed, FramesProcessed, RigEvent
from wiithrow.app.rig.pipeline import TrackingPipeline
from wiithrow.app.rig.stage_stamps import StageStamps
from wiithrow.app.session import Session, demo_target_base, simulated_session
from wiithrow.vision.tracker import TrackedFrame
from wiithrow.web.server import Dashboard

#: Host-side goal: report read -> every event-driven consumer, p99 (ms).
GOAL_P99_MS = 1.0
#: Seconds run before measuring (the kernels compile, the tracks settle).
WARM_UP_S = 1.0
RIG_NAME = "bench-latency"


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


class _StampedPublisher(RigPublisher):
    """The publisher, stamping each frame when its put returned (in the follower's thread)."""

    stamps: StageStamps

    def publish_markers(self, frame: TrackedFrame, sent: float | None = None) -> int:
        seq = super().publish_markers(frame, sent)
        self.stamps.delivered("publisher", frame.t)
        return seq


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


def measure(seconds: float, *, attached: bool) -> dict[str, Any]:
    """One configuration: with the dashboard and the recorder attached (`attached`), or without."""
    session: Session = simulated_session(seed=0, calibration="true", realtime=True, quiet=True)
    world = session.world
    rig = world.rig
    if not isinstance(rig, TrackingPipeline):
        raise TypeError(f"bench latency needs the local rig, not {type(rig).__name__}")
    session.set_target(demo_target_base())
    stamps = StageStamps(world.clock)
    zenoh = open_session()
    dashboard: Dashboard | None = None
    recorder: SessionRecorder | None = None
    follower: RigFollower | None = None
    with tempfile.TemporaryDirectory(prefix="wiithrow-bench-latency-") as folder:
        try:
            if attached:  # (it does not listen to the rig: built first, out of the rig's lock)
                dashboard = _StampedDashboard(session, port=0)
                dashboard.stamps = stamps
            with rig.lock:  # between two polls: every consumer sees the same frames
                rig.stamps = stamps
                publisher = _StampedPublisher(zenoh, RIG_NAME, rig.camera_names, "link1")
                publisher.stamps = stamps
                follower = RigFollower(publisher, rig)  # as `publish_session` does, before `run_dashboard`
                follower.start()
                if attached:  # as `run_dashboard(record=...)` does
                    recorder = SessionRecorder(session, Path(folder) / "run.mcap")
                    recorder.begin()
                    rig.subscribe(lambda event: _stamp_recorder(stamps, event))
                rig.subscribe(_SessionReads(stamps))
            if dashboard is not None:
                dashboard.start()  # starts the session's rig loop too
            else:
                session.start()
            time.sleep(WARM_UP_S)
            stamps.restart()
            time.sleep(seconds)
            with rig.lock:
                rig.stamps = None
        finally:
            session.stop()
            if dashboard is not None:
                dashboard.close()
            if recorder is not None:
                recorder.close()
            session.close()
            if follower is not None:
                follower.stop()
            zenoh.close()
    names = CONSUMERS if attached else BARE
    consumers = {name: summary(stamps.delivered_after.get(name, [])) for name in names}
    return {
        "stages": {stage: summary(values) for stage, values in stamps.since_read.items()},
        "consumers": consumers,
        "report_to_consumer_p99_ms": max(float(c["p99_ms"]) for name, c in consumers.items() if name != "dashboard"),
        "deliveries_without_stamps": stamps.unknown_deliveries,
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
