"""`BallEvents`: what the MuJoCo lab saw of the ball in the current throw, from its load to its
touchdown (`lab.MujocoLab.events`; times on the world's clock, positions in base)."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray


@dataclass
class BallEvents:
    """What the lab saw of the ball in the current throw (times on the clock, positions in base)."""

    opened_at: float | None = None  # the fingers started to open
    released_at: float | None = None  # no pad touched the ball any more
    gripped: bool = False  # the closed fingers held it (`MujocoLab.holding`)
    lost_at: float | None = None  # it left the closed fingers before they opened
    lost_open_at: float | None = None  # the fingers opened after it had left them
    release_position: NDArray[np.float64] | None = None
    release_velocity: NDArray[np.float64] | None = None
    release_spin: NDArray[np.float64] | None = None  # angular velocity, rad/s
    release_q: NDArray[np.float64] | None = None  # the arm's joints then
    release_dq: NDArray[np.float64] | None = None
    # where the ball sat in the hand (its centre in the ball seat's frame, m) when it was loaded and
    # held, and at the release: how far a grip let it shift
    held_in_hand: NDArray[np.float64] | None = None
    release_in_hand: NDArray[np.float64] | None = None
    touchdown_at: float | None = None
    touchdown: NDArray[np.float64] | None = None  # the first contact point with the floor or the table
    marker: NDArray[np.float64] | None = None  # where the operator put the landing LED
    path_t: list[float] = field(default_factory=list)
    path: list[NDArray[np.float64]] = field(default_factory=list)
