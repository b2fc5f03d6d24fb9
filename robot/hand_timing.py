"""How long a hand takes to close and to open, measured on its clock rather than assumed.

A hand's jaws have *settled* after a close when the hand says it holds something (`holding` is
True), or (after any command, and for a hand that cannot tell or holds nothing) when its opening
has moved since the command and then stayed within `JAWS_STILL_OPENING` of one value for
`JAWS_STILL_S`: the jaws stopped (on the ball, on each other, or at their open end). The settle time is when they first
reached that value, not when the stillness was confirmed. `JawsSettle` follows one command's
states; `measure_close_time` and `measure_open_time` command the hand and time it, for a caller
that may move the jaws (`wiithrow check-driver`'s hand probe; a lab stating its hand's times in the
settings, `hand_close_s` and `hand_open_s`). `wiithrow.app.worlds.grip` waits for the grip with
the same `JawsSettle`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from wiithrow.robot.errors import RobotError
from wiithrow.robot.gripper import Gripper, GripperState
from wiithrow.robot.interface import Clock

#: How much (a fraction of the stroke) the opening may change and the jaws still count as at rest:
#: a real hand's reported opening is quantised and noisy by about a percent of its stroke.
JAWS_STILL_OPENING = 0.01
#: How long (s) the opening must stay within JAWS_STILL_OPENING to count as settled: three readings
#: of a hand read every 10 ms, so that one reading between two steps of a slow jaw is not taken for
#: a stop.
JAWS_STILL_S = 0.03
#: The step (s) in which `measure_close_time` / `measure_open_time` read the hand: 2 ms, a fifth of
#: the shortest latency the simulated hands have.
MEASURE_STEP_S = 0.002
#: How long (s) the measurements wait for the jaws to settle before saying they did not.
MEASURE_TIMEOUT_S = 5.0


@dataclass
class JawsSettle:
    """Follows the hand's states after one command (`closing`: a close, whose `holding` counts),
    given the state `start` read just before it (module docstring). `settled_at`: when the jaws
    settled (the hand's clock), None until then."""

    start: GripperState
    closing: bool
    settled_at: float | None = None
    _moved: bool = False
    _value: float = math.nan
    _since: float = math.nan

    def feed(self, state: GripperState) -> bool:
        """Take one state read after the command; True once the jaws settled."""
        if self.settled_at is not None:
            return True
        if self.closing and state.holding:
            self.settled_at = state.t
            return True
        opening = float(state.opening)
        self._moved = self._moved or abs(opening - self.start.opening) > JAWS_STILL_OPENING
        if not math.isfinite(self._value) or abs(opening - self._value) > JAWS_STILL_OPENING:
            self._value, self._since = opening, state.t
        if self._moved and state.t - self._since >= JAWS_STILL_S - 1e-9:
            self.settled_at = self._since
            return True
        return False


def measure_close_time(gripper: Gripper, clock: Clock, *, timeout_s: float = MEASURE_TIMEOUT_S) -> float:
    """The hand's close time (s): from `close()` until its jaws settled (`JawsSettle`: it holds,
    or its jaws stopped). The hand is opened first, unless it rests open already, and waited for
    (so the close is a whole stroke); it is left closed. Reads it every MEASURE_STEP_S on `clock`
    (on a simulated clock, time passes through `clock.sleep`). RobotError when the jaws do not
    settle within `timeout_s` (s)."""
    _come_to(gripper, clock, "open", timeout_s)
    return _time_command(gripper, clock, "close", timeout_s)


def measure_open_time(gripper: Gripper, clock: Clock, *, timeout_s: float = MEASURE_TIMEOUT_S) -> float:
    """The hand's open time (s): from `open()` until its jaws stopped at their open end. The hand
    is closed first, unless it rests closed already, and is left open. RobotError as
    `measure_close_time`."""
    _come_to(gripper, clock, "close", timeout_s)
    return _time_command(gripper, clock, "open", timeout_s)


def _come_to(gripper: Gripper, clock: Clock, command: str, timeout_s: float) -> None:
    """Bring the jaws to rest as `command` leaves them: nothing when the hand was told so already
    and its jaws stay still over JAWS_STILL_S (a command that changes nothing moves no jaw, so its
    settling could not be seen), else the command, waited for."""
    before = gripper.state()
    if before.command == ("open" if command == "open" else "closed"):
        clock.sleep(JAWS_STILL_S)
        if abs(gripper.state().opening - before.opening) <= JAWS_STILL_OPENING:
            return
    _time_command(gripper, clock, command, timeout_s)


def _time_command(gripper: Gripper, clock: Clock, command: str, timeout_s: float) -> float:
    """Command `command` ("open" or "close") and return how long (s) until the jaws settled."""
    settle = JawsSettle(gripper.state(), closing=command == "close")
    told = clock.now()
    gripper.open() if command == "open" else gripper.close()
    while not settle.feed(gripper.state()):
        if clock.now() - told > timeout_s:
            raise RobotError(f"the hand's jaws did not settle within {timeout_s:.1f} s of {command}()")
        clock.sleep(MEASURE_STEP_S)
    assert settle.settled_at is not None  # feed returned True
    return max(0.0, settle.settled_at - told)
