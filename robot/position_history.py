"""`PositionHistory`: the joint positions (and velocities) a simulated arm reported over its last
servo steps.

A simulated camera's frame shows the scene at its exposure time, which on a real-time clock can lie
in the past by the time the frame is made: a host that was not scheduled for a while makes the
frames it missed all at once (`wiithrow.app.worlds.simulated.SimWorld.sources_at`). The arm has
stepped on meanwhile; this ring keeps the position of each step so that such a frame shows the arm
where it was then. It keeps each step's velocity beside it (when given: NaN otherwise) for a
world that takes the ball's release state after the hand opened, however late it gets round to it
(`SimWorld.after_open`). Rows are by step number k (row k % size); what is older than `size`
steps is gone.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray


class PositionHistory:
    """The positions (rad) and velocities (rad/s) of the last `size` steps of an arm of `joints` joints."""

    def __init__(self, size: int, joints: int) -> None:
        if size < 1:
            raise ValueError(f"a position history keeps at least one step, not {size}")
        self.size = int(size)
        self._q = np.zeros((self.size, joints))
        self._v = np.full((self.size, joints), np.nan)
        self._newest = -1  # the newest step kept (-1: none)

    def keep(self, k: int, q: NDArray[np.float64], v: NDArray[np.float64] | None = None) -> None:
        """Step k's position (and velocity)."""
        self._q[k % self.size] = q
        self._v[k % self.size] = np.nan if v is None else v
        self._newest = k

    def keep_steps(self, k: int, positions: NDArray[np.float64], velocities: NDArray[np.float64] | None = None) -> None:
        """Steps k, k + 1, ... (one row of `positions`, and of `velocities`, each); a single row (1,
        n) for all of steps k..k + count - 1 is `keep_same`."""
        count = positions.shape[0]
        last = k + count - 1
        first = max(k, last - self.size + 1)  # more than the ring holds: the newest
        rows = np.arange(first, last + 1) % self.size
        self._q[rows] = positions[first - k :]
        self._v[rows] = np.nan if velocities is None else velocities[first - k :]
        self._newest = last

    def keep_same(self, k: int, count: int, q: NDArray[np.float64], v: NDArray[np.float64] | None = None) -> None:
        """Steps k..k + count - 1 all at `q` (and `v`: an arm at rest)."""
        if count <= 0:
            return
        last = k + count - 1
        first = max(k, last - self.size + 1)
        rows = np.arange(first, last + 1) % self.size
        self._q[rows] = q
        self._v[rows] = np.nan if v is None else v
        self._newest = last

    def at(self, k: int) -> NDArray[np.float64] | None:
        """Step k's position (a copy), or None when it is not kept (too old, or not taken yet)."""
        if self._newest - self.size < k <= self._newest:
            kept: NDArray[np.float64] = self._q[k % self.size].copy()
            return kept
        return None

    def state(self, k: int) -> tuple[NDArray[np.float64], NDArray[np.float64]] | None:
        """Step k's (position, velocity) (copies; NaN velocities where none was given), or None
        when it is not kept."""
        if self._newest - self.size < k <= self._newest:
            return self._q[k % self.size].copy(), self._v[k % self.size].copy()
        return None
