"""What a marker source tells its listeners: a small, typed set of events.

Every `wiithrow.app.rig.source.MarkerSource` has one stream of these (`subscribe(listener)`,
`wiithrow.listeners.Listeners`), emitted in the order things happen, under the source's lock:

* `ReportsRead(camera, batch)`: raw input reports a local remote's driver read, (arrival time,
  bytes), before they are decoded (what a recording keeps; only the local rig has them);
* `FramesProcessed(camera, frames, tracked)`: one camera's decoded frames went through the
  synchroniser, and the tracked frames they completed (also when a frame was refused: `tracked`
  holds what was made before);
* `Flushed(now, synced, tracked)`: the frames that waited long enough by `now` (a silent camera)
  were synchronised (`synced` of them) and tracked;
* `CalibrationChanged(Ps, revision)`: tracking uses these projection matrices from now on; the
  revision counts calibrations from 1 (a new tracker: track ids restart).

Replaying `FramesProcessed`, `Flushed` and `CalibrationChanged` in order through the same
pipeline gives the same markers (`wiithrow.app.recording.replay`).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from wiithrow.vision.tracked_frame import TrackedFrame
from wiithrow.vision.wiimote.frames import IRFrame


@dataclass(frozen=True, eq=False)
class ReportsRead:
    camera: int
    batch: Sequence[tuple[float, bytes]]


@dataclass(frozen=True, eq=False)
class FramesProcessed:
    camera: int
    frames: Sequence[IRFrame]
    tracked: Sequence[TrackedFrame]


@dataclass(frozen=True, eq=False)
class Flushed:
    now: float
    synced: int
    tracked: Sequence[TrackedFrame]


@dataclass(frozen=True, eq=False)
class CalibrationChanged:
    Ps: NDArray[np.float64]
    revision: int


RigEvent = ReportsRead | FramesProcessed | Flushed | CalibrationChanged
RigListener = Callable[[RigEvent], object]
