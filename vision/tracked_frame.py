"""What the tracker gives for a frame: its confirmed markers with their ids (`TrackedFrame`, one
`TrackedMarker` each on demand).

Its own module so that a process that only carries tracked frames (a publisher's writer process,
a recording's reader) imports numpy and this, not the tracker's Kalman kernels (numba) and its
assignment (scipy): 0.4 s of every such process's start.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray


@dataclass(frozen=True)
class TrackedMarker:
    """A confirmed marker in one frame, in the calibration's frame (metres, m/s)."""

    id: int
    t: float
    position: NDArray[np.float64]
    velocity: NDArray[np.float64]
    filtered: NDArray[np.float64]
    visible: bool
    n_views: int


@dataclass(frozen=True)
class TrackedFrame:
    """The confirmed markers of one frame, as arrays ordered by id (M markers).

    position: the triangulated measurement when visible, the prediction while hidden; filtered:
    the Kalman estimate; velocity: the Kalman velocity; n_views: cameras that saw it (0: hidden).
    """

    t: float
    ids: NDArray[np.int64]
    position: NDArray[np.float64]
    velocity: NDArray[np.float64]
    filtered: NDArray[np.float64]
    visible: NDArray[np.bool_]
    n_views: NDArray[np.int64]

    def __len__(self) -> int:
        return len(self.ids)

    def markers(self) -> list[TrackedMarker]:
        """One object per marker (convenient, slower than the arrays)."""
        return [
            TrackedMarker(int(i), self.t, p, v, f, bool(vis), int(n))
            for i, p, v, f, vis, n in zip(
                self.ids, self.position, self.velocity, self.filtered, self.visible, self.n_views
            )
        ]
