"""The target as the alignment measures it: its position in link1 and its azimuth in base.

Every tracked frame gives the target's position p = (x, y, z) in link1 at the frame's time t_f;
link1 is base turned by q1 about z, so the target's azimuth in base is

    psi = q1(t_f) + atan2(y, x),

with q1(t_f) the measured joint-1 angle interpolated at t_f (`JointHistory`). `TargetEstimate`
keeps the last positions (their mean is the measurement) with joint 1's angle at each (their mean,
`joint1`, is the angle link1 was at for that mean: what takes it to base), the azimuth's recent
values and its
rate psi_dot (a least-squares slope over `rate_window_s`), which lets the alignment follow a
moving target without a proportional law's lag. Which marker is the target: the tracker's id
once locked, else the visible marker nearest to the last position (`pick_target`).
"""

from __future__ import annotations

import math
from collections import deque

import numpy as np
from numpy.typing import NDArray

from wiithrow.app.alignment.room_check import Sighting
from wiithrow.vision.tracked_frame import TrackedFrame


class JointHistory:
    """Measured joint-1 angles by time, to know where link1 pointed when a frame was taken."""

    def __init__(self, size: int = 200) -> None:
        self.t: deque[float] = deque(maxlen=size)
        self.q: deque[float] = deque(maxlen=size)

    def add(self, t: float, q1: float) -> None:
        self.t.append(t)
        self.q.append(q1)

    def at(self, t: float) -> float:
        return float(np.interp(t, np.array(self.t), np.array(self.q)))


def azimuth_rate(t: deque[float], psi: deque[float], window_s: float) -> float:
    """Least-squares slope of psi over time (rad/s), 0 until it spans half the window."""
    if len(t) < 5 or t[-1] - t[0] < 0.5 * window_s:
        return 0.0
    tt = np.array(t) - t[-1]
    pp = np.array(psi)
    tc = tt - tt.mean()
    return float(tc @ (pp - pp.mean()) / (tc @ tc))


def pick_target(
    frame: TrackedFrame, target_id: int | None, last: NDArray[np.float64] | None, reacquire_m: float = 0.2
) -> tuple[NDArray[np.float64] | None, int | None]:
    """The target's measured position in this frame (None if not seen) and its track id: the
    locked id if visible, else a visible marker within `reacquire_m` of the last position (the
    tracker may have restarted the track), else, before any lock, the first visible marker."""
    visible = np.flatnonzero(frame.visible)
    if visible.size == 0:
        return None, target_id
    if target_id is not None:
        same = visible[frame.ids[visible] == target_id]
        if same.size:
            return frame.position[same[0]], target_id
    if last is not None:
        d = np.linalg.norm(frame.position[visible] - last, axis=1)
        i = int(np.argmin(d))
        if d[i] <= reacquire_m:
            return frame.position[visible[i]], int(frame.ids[visible[i]])
        return None, target_id
    return frame.position[visible[0]], int(frame.ids[visible[0]])


class TargetEstimate:
    """The target's recent measurements (see the module docstring).

    `average_frames`: positions averaged for the measurement; `rate_window_s` (s): the window of the
    azimuth rate; `period_s` (s): the alignment's tick, for how long a measurement stays current.
    """

    def __init__(self, average_frames: int, rate_window_s: float, period_s: float) -> None:
        self.joint = JointHistory()
        self.recent: deque[NDArray[np.float64]] = deque(maxlen=average_frames)
        self.recent_q1: deque[float] = deque(maxlen=average_frames)  # joint 1 at each of `recent`
        self.rate_window_s = rate_window_s
        self.period_s = period_s
        self.target_id: int | None = None
        self.last_seen = -np.inf
        self.ever_seen = False
        self.psi = float("nan")
        self.psi_t: deque[float] = deque(maxlen=int(rate_window_s / period_s) + 1)
        self.psi_v: deque[float] = deque(maxlen=self.psi_t.maxlen)

    def add(self, frames: list[TrackedFrame], now: float) -> list[Sighting]:
        """Take the target's position from each frame that shows it (seen `now`, on the clock).
        Returns the target's sightings in these frames (frame time, joint 1 then, azimuth in link1)."""
        sightings: list[Sighting] = []
        for frame in frames:
            p, self.target_id = pick_target(frame, self.target_id, self.recent[-1] if self.recent else None)
            if p is not None:
                q1, azimuth = self.joint.at(frame.t), math.atan2(p[1], p[0])
                self.recent.append(p)
                self.recent_q1.append(q1)
                self.last_seen, self.ever_seen = now, True
                self.psi = q1 + azimuth
                self.psi_t.append(frame.t)
                self.psi_v.append(self.psi)
                sightings.append(Sighting(frame.t, q1, azimuth))
        return sightings

    def y_mean(self, now: float) -> float:
        """Mean y (m, link1) of the last positions if seen within 1.5 ticks, else NaN."""
        if self.recent and now - self.last_seen <= self.period_s * 1.5:
            return float(np.mean([p[1] for p in self.recent]))
        return float("nan")

    def rate(self) -> float:
        """The azimuth's rate psi_dot (rad/s), 0 until the window is half full."""
        return azimuth_rate(self.psi_t, self.psi_v, self.rate_window_s)

    def position(self) -> NDArray[np.float64]:
        """The measurement: the mean of the last positions (link1, m); NaN if never seen."""
        return np.mean(np.array(self.recent), axis=0) if self.recent else np.full(3, np.nan)

    def joint1(self) -> float:
        """Joint 1's angle (rad) for `position`: the mean of its readings at the positions' frames;
        NaN if never seen."""
        return float(np.mean(self.recent_q1)) if self.recent_q1 else float("nan")

    def distance(self) -> float:
        """Horizontal distance (m) of the last position from joint 1's axis."""
        p = self.recent[-1]
        return math.hypot(p[0], p[1])
