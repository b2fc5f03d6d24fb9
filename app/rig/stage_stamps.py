"""When each tracked frame passed each stage of the local tracking path: `StageStamps`.

A `TrackingPipeline` fills one when it is given one (`pipeline.stamps`, None by default: the hot
path then pays one `is not None` test per report). Per tracked frame, keyed by its time `t`
(`TrackedFrame.t`, unique within a run), on the pipeline's clock (the one clock of
`wiithrow.clock`, on which the drivers stamp arrivals too):

* `read`: when the driver's link read the report that completed it (`IRFrame.t`, its arrival);
* `decoded`: when the pipeline was handed the decoded frames (`process` called: the driver
  decoded its batch just before, in the same thread);
* `synced`: when the synchroniser returned it (`vision/sync.py`);
* `tracked`: when the tracker returned it (`vision/tracker.py`).

Whoever measures a consumer says when that consumer got a frame (`delivered(consumer, t, now)`);
the latency kept is `now - read`. Only the newest `capacity` frames' stamps are kept, and every
list grows by one float per frame (a 60 s run at 100 Hz: 6,000 per list).
"""

from __future__ import annotations

from collections import OrderedDict

from wiithrow.clock import Clock

#: The stages the pipeline stamps, in order.
STAGES = ("read", "decoded", "synced", "tracked")


class StageStamps:
    """Stage times of tracked frames and their delivery to consumers (see the module docstring)."""

    def __init__(self, clock: Clock, capacity: int = 1_000) -> None:
        self.clock = clock
        self.capacity = int(capacity)
        self._rows: OrderedDict[float, tuple[float, float, float, float]] = OrderedDict()
        #: per stage after `read`: seconds from the read, one entry per tracked frame
        self.since_read: dict[str, list[float]] = {stage: [] for stage in STAGES[1:]}
        #: per consumer: seconds from the read to its delivery
        self.delivered_after: dict[str, list[float]] = {}
        self.unknown_deliveries = 0  # frames a consumer got whose stamps were not (or no longer) kept
        self.frames_stamped = 0  # every frame stamped since it was made (`restart` keeps it)

    def restart(self) -> None:
        """Forget the latencies measured so far (the warm-up's); the stamps kept stay."""
        self.since_read = {stage: [] for stage in STAGES[1:]}
        self.delivered_after = {}
        self.unknown_deliveries = 0

    def frame(self, t: float, read: float, decoded: float, synced: float, tracked: float) -> None:
        """Stamp one tracked frame (called by the pipeline, under its lock)."""
        rows = self._rows
        rows[t] = (read, decoded, synced, tracked)
        self.frames_stamped += 1
        if len(rows) > self.capacity:
            rows.popitem(last=False)
        since = self.since_read
        since["decoded"].append(decoded - read)
        since["synced"].append(synced - read)
        since["tracked"].append(tracked - read)

    def stages(self, t: float) -> tuple[float, float, float, float] | None:
        """(read, decoded, synced, tracked) of the frame at time `t`, None when not kept."""
        return self._rows.get(t)

    def delivered(self, consumer: str, t: float, now: float | None = None) -> None:
        """Consumer `consumer` got the tracked frame of time `t` at `now` (the clock's now by default)."""
        row = self._rows.get(t)
        if row is None:
            self.unknown_deliveries += 1
            return
        at = self.clock.now() if now is None else now
        self.delivered_after.setdefault(consumer, []).append(at - row[0])
