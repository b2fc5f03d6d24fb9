"""The local rig: C Wiimote drivers -> report decoders -> synchroniser -> tracker.

`RigStream` is the `MarkerSource` (`source`) of this host's remotes: a `TrackingPipeline`
(`pipeline`: synchroniser, tracker, kept frames, calibration and its revision, the event stream)
fed by one `WiimoteDriver` per camera (each decoding its bytes with a `ReportDecoder`). Before
there is a calibration it still reads the remotes and keeps each camera's recent frames (what the
robot-driven calibration averages). It works the same over real remotes and simulated ones: with
a simulated clock `wiithrow.app.rig.waiting.pump` advances time and calls `poll()`, with the
system clock a loop calls `poll()` at its own pace (each driver's reports queue up in the HID
buffer meanwhile).

Frames are synchronised on the driver's estimate of when the remote sent them (`t_device`), which
removes the jitter of reading reports in batches. `poll` and the pipeline's steps are serialised
by one lock, so that several readers (an operation, the dashboard) see the same frames.

Besides the pipeline's events, the rig tells its listeners every batch of raw reports its drivers
read (`ReportsRead`, from each driver's report listeners, under the same lock while it polls):
what a recording keeps, and what its replay decodes again.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray

from wiithrow.app.rig.pipeline import SynchronizerFactory, TrackerFactory, TrackingPipeline
from wiithrow.clock import Clock
from wiithrow.listeners import Unsubscribe, batch
from wiithrow.vision.sync import FrameSynchronizer
from wiithrow.vision.tracker import MarkerTracker
from wiithrow.vision.wiimote.device import WiimoteDriver


class RigStream(TrackingPipeline):
    """This host's remotes as a marker source (see the module docstring); `Ps=None`: no
    calibration yet. The clock is the drivers' unless given."""

    def __init__(
        self,
        drivers: Sequence[WiimoteDriver],
        Ps: NDArray[np.float64] | None = None,
        *,
        clock: Clock | None = None,
        synchronizer: SynchronizerFactory = FrameSynchronizer,
        tracker: TrackerFactory = MarkerTracker,
        history: int = 100,
    ) -> None:
        self.drivers = list(drivers)
        super().__init__(
            [d.name for d in self.drivers],
            clock if clock is not None else self.drivers[0].clock,
            Ps,
            synchronizer=synchronizer,
            tracker=tracker,
            history=history,
        )
        self._taps: list[Unsubscribe] = [
            driver.subscribe_reports(self.reports_listener(camera)) for camera, driver in enumerate(self.drivers)
        ]

    def connect(self) -> None:
        """Open every remote and start its camera (raises WiimoteError if one cannot start)."""
        for driver in self.drivers:
            driver.connect()

    def close(self) -> None:
        for driver in self.drivers:
            driver.close()

    def quiet_until(self) -> float:
        """A clock time before which `poll()` reads, tracks and tells nothing: every driver quiet
        (`WiimoteDriver.quiet_until`), no reference frame due to be flushed, and no listener (who
        would be told of each empty poll); -inf when a poll may do something now."""
        if self.events:
            return -math.inf
        with self._lock:
            quiet = self.sync.quiet_until()
            for driver in self.drivers:
                quiet = min(quiet, driver.quiet_until())
            return quiet

    def poll(self, timeout_s: float = 0.0) -> None:
        """Read what every remote has sent and track it (the frames: `tracked_since`). The poll's
        events are one batch (`wiithrow.listeners.batch`): what a listener defers to its end runs
        after the lock is released."""
        with batch(), self._lock:
            for camera, driver in enumerate(self.drivers):
                self.process(camera, driver.poll(timeout_s if camera == 0 else 0.0))
            self.flush(self.clock.now())
