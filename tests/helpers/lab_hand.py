"""`LabHand`: a test double of a two-finger hand that holds a ball and says so, with its own close
time, latency and stroke, as a lab's hand may have them (issue: a hand whose pads hold a 57 g
ball with about 1.6 N lost it within a few ms of opening, yet took 85-95 ms to open to 90 %).

The jaws move linearly: closing, from where they are to `BALL_OPENING` (the ball between them)
in `close_s` after `latency_s`; opening, from there to 1 in `stroke_s` after `latency_s`. A ball is
put between them at every close (the operator) and held while they are closed on it; it is free
once they opened `free_opening` beyond it. Opens can be scheduled (`open_at`) on the clock.
"""

from __future__ import annotations

from wiithrow.clock import Clock
from wiithrow.robot.gripper import GripperCommand, GripperState

#: The jaws' opening with the ball between them (0 closed on nothing, 1 fully open).
BALL_OPENING = 0.6


class LabHand:
    """The hand of the module docstring."""

    def __init__(
        self, clock: Clock, *, latency_s: float, stroke_s: float, close_s: float, free_opening: float = 0.02
    ) -> None:
        self.clock = clock
        self.latency_s, self.stroke_s, self.close_s, self.free_opening = latency_s, stroke_s, close_s, free_opening
        self._command: GripperCommand = "open"
        self._since = float("-inf")  # when the last command was given (its time on the clock)
        self._from = 1.0
        self._due: float | None = None  # a scheduled open's time

    def _settle(self) -> None:
        if self._due is not None and self.clock.now() >= self._due:
            due, self._due = self._due, None
            self._give("open", due)

    def _opening_at(self, t: float) -> float:
        moving = t - self._since - self.latency_s
        if moving <= 0:
            return self._from
        if self._command == "open":
            return min(1.0, self._from + moving / self.stroke_s * (1.0 - BALL_OPENING))
        return max(BALL_OPENING, self._from - moving / self.close_s * (1.0 - BALL_OPENING))

    def _give(self, command: GripperCommand, t: float) -> None:
        self._from = self._opening_at(t)
        self._command, self._since = command, t

    def open(self) -> None:
        self._settle()
        self._due = None
        self._give("open", self.clock.now())

    def open_at(self, t: float) -> None:
        self._settle()
        self._due = max(float(t), self.clock.now())
        self._settle()

    def cancel_open(self) -> bool:
        self._settle()
        cancelled, self._due = self._due is not None, None
        return cancelled

    def close(self) -> None:
        self._settle()
        self._due = None
        self._give("closed", self.clock.now())

    def state(self) -> GripperState:
        self._settle()
        now = self.clock.now()
        opening = self._opening_at(now)
        holding = self._command == "closed" and opening <= BALL_OPENING + 1e-9
        holding |= self._command == "open" and opening < BALL_OPENING + self.free_opening
        return GripperState(now, self._command, opening, holding)
