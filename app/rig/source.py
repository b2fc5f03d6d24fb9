"""`MarkerSource`: what every consumer of tracked markers needs, whoever tracks them.

Three implementations, sharing no fakes:

* the local rig, `wiithrow.app.rig.stream.RigStream`: this host's remotes' drivers ->
  `ReportDecoder` -> synchroniser -> tracker;
* the remote source, `wiithrow.app.network.remote_rig.RemoteRig`: the frames another host
  tracked and published over Zenoh, restamped on this clock;
* the replay, `wiithrow.app.recording.replay.Replay`: a recording's raw reports -> the same
  `ReportDecoder` -> the same synchroniser and tracker.

The consumers (the session, the alignment, a throw's measurement, the calibrations, the
dashboard, a recording, the publisher) use only this: they let time pass on the source's clock
with `wiithrow.app.rig.waiting.pump` (which calls `poll` after each step), read what was tracked
with `tracked_since(t)` (the one way to read frames, whoever else polls), and listen to one
stream of events (`subscribe`, `wiithrow.app.rig.events`) instead of polling for a change; a
recalibration is a `CalibrationChanged` event and a higher `calibration_revision`.
"""

from __future__ import annotations

import threading
from collections.abc import Sequence
from typing import TYPE_CHECKING, Protocol

import numpy as np
from numpy.typing import NDArray

from wiithrow.app.rig.events import RigListener
from wiithrow.clock import Clock
from wiithrow.listeners import Unsubscribe
from wiithrow.vision.tracked_frame import TrackedFrame
from wiithrow.vision.wiimote.frames import IRFrame

if TYPE_CHECKING:  # (an annotation only: the synchroniser's module brings the numba kernels)
    from wiithrow.vision.sync import SyncedFrame


class MarkerSource(Protocol):
    """Tracked 3D markers and each camera's dots, on one clock (see the module docstring)."""

    clock: Clock

    @property
    def camera_names(self) -> Sequence[str]:
        """The cameras' names (cam0, ...), in the order of their LEDs."""

    @property
    def Ps(self) -> NDArray[np.float64] | None:
        """The projection matrices (C, 3, 4) tracking uses, None before a calibration."""

    @property
    def calibrated(self) -> bool:
        """Whether markers are tracked (`Ps` is not None)."""

    @property
    def calibration_revision(self) -> int:
        """How many calibrations the source tracked with so far (0: none yet)."""

    @property
    def lock(self) -> threading.RLock:
        """Held while the source reads and tracks (and while it tells its listeners)."""

    def calibration_refused(self) -> str:
        """Why this source cannot be calibrated here ("" when it can)."""

    def set_calibration(self, Ps: NDArray[np.float64]) -> None:
        """Track with these projection matrices from now on."""

    def subscribe(self, listener: RigListener) -> Unsubscribe:
        """Tell `listener` every event (`wiithrow.app.rig.events`) from now on."""

    def connect(self) -> None: ...

    def close(self) -> None: ...

    def poll(self) -> None:
        """Take in what arrived (reports, published frames, recorded messages) up to the clock's now."""

    def tracked_since(self, t: float) -> list[TrackedFrame]:
        """The kept tracked frames later than time t, oldest first."""

    def latest_tracked(self) -> TrackedFrame | None: ...

    def synced_since(self, t: float) -> list[SyncedFrame]:
        """The kept synchronised frames (calibrated or not) later than t; none from a remote source."""

    @property
    def latest(self) -> list[IRFrame | None]:
        """Every camera's most recent frame (None before the first)."""

    def recent(self, camera: int, count: int) -> list[IRFrame]:
        """Camera `camera`'s last `count` frames, oldest first."""

    def latest_dots(self) -> NDArray[np.float64]:
        """Every camera's most recent dots (C, 4, 2), NaN where none."""


def newest_t(source: MarkerSource) -> float:
    """The time of the newest tracked frame kept (-inf before one): `tracked_since(newest_t(s))`
    after letting time pass gives exactly the frames tracked meanwhile."""
    newest = source.latest_tracked()
    return newest.t if newest is not None else -np.inf
