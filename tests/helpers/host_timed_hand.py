"""`HostTimedHand`: a world's hand seen through a driver that cannot schedule an open (no
`open_at`), the fallback `execute_throw` keeps: the host tells it `open()` when the release
time comes."""

from __future__ import annotations

from typing import Any

import numpy as np

from wiithrow.robot.gripper import Gripper, GripperState


class HostTimedHand:
    """`hand`'s open, close and state only (and what the simulated worlds ask of their hands)."""

    def __init__(self, hand: Gripper) -> None:
        self.hand = hand

    def open(self) -> None:
        self.hand.open()

    def close(self) -> None:
        self.hand.close()

    def state(self) -> GripperState:
        return self.hand.state()

    # what the simulated worlds' operators and flights use of their own hands
    @property
    def opened_at(self) -> float | None:
        hand: Any = self.hand
        return hand.opened_at

    def load_ball(self) -> None:
        hand: Any = self.hand
        hand.load_ball()

    def ball_position(self) -> np.ndarray:
        hand: Any = self.hand
        return hand.ball_position()

    @property
    def lost_at(self) -> float | None:
        hand: Any = self.hand
        return hand.lost_at
