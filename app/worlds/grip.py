"""The ball in the hand: closing the hand on it (`close_on_ball`, what `RigWorld.load_ball` runs),
how long that may take, and the error of a ball that left the hand before the release (`BallLost`).

**The grip wait.** The hand is told to close and read every `GRIP_STEP_S` until its jaws settled
(`wiithrow.robot.hand_timing.JawsSettle`: it says it holds the ball, or, for a hand that cannot
tell, its jaws moved and stopped), then the grip settles for `GRIP_SETTLE_S`. The wait is bounded
by `GRIP_WAIT_FACTOR` times the hand's close time: the settings' `hand_close_s` when they state it,
else the close time measured at this world's last load that held, else `DEFAULT_HAND_CLOSE_S`. A
hand that has not closed on the ball by then is opened again and the throw refused in one line,
which names the bound and where its close time came from; nothing moved.
"""

from __future__ import annotations

from collections.abc import Callable

from wiithrow.app.errors import AppError
from wiithrow.robot.gripper import Gripper
from wiithrow.robot.hand_timing import JawsSettle

#: The close time (s) assumed for a hand whose settings do not state one (`hand_close_s`) before
#: a load measured it: twice it is the 0.5 s the grip was always given, which the simulated hands
#: (10-80 ms) and the PA-10's rehearsed hand meet with room.
DEFAULT_HAND_CLOSE_S = 0.25
#: How many times its close time a hand is given to close on the ball: a hand's close varies with
#: where the ball sits between its jaws and with its latency's jitter; twice the close time leaves
#: room for that while a hand that never closes is told within a second for the lab's 0.4 s hand.
GRIP_WAIT_FACTOR = 2.0
#: How often (s) the hand is read while it closes.
GRIP_STEP_S = 0.005
#: How long (s) the grip is let settle once the jaws are on the ball, before the arm moves.
GRIP_SETTLE_S = 0.05

#: Waits `seconds` (s) on the world's clock, reading the rig meanwhile (`app.rig.waiting.pump`).
Wait = Callable[[float], None]


class BallLost(AppError):
    """The ball left the hand before the release: the hand said it no longer held it (or its jaws
    moved off the ball's width) while it was told to stay closed. `before_release_s`: how long
    (s) before the release the hand was seen without it (None: unknown); `before`: the instant it
    is measured to (the release, or when the hand opened)."""

    def __init__(self, before_release_s: float | None, before: str = "the release") -> None:
        when = "" if before_release_s is None else f"{max(0.0, before_release_s):.3f} s "
        super().__init__(f"the ball left the hand in the wind-up ({when}before {before})")
        self.before_release_s = None if before_release_s is None else max(0.0, float(before_release_s))


def close_time_s(stated_s: float, measured_s: float | None) -> tuple[float, str]:
    """The hand's close time (s) the grip wait is bounded by, and where it came from, in words:
    `stated_s` (the settings' `hand_close_s`; 0: not stated), else `measured_s` (this world's last
    load that held), else DEFAULT_HAND_CLOSE_S."""
    if stated_s > 0:
        return float(stated_s), f"{stated_s:.2f} s, the settings' hand_close_s"
    if measured_s is not None:
        return float(measured_s), f"{measured_s:.2f} s, measured at the last load"
    return DEFAULT_HAND_CLOSE_S, f"{DEFAULT_HAND_CLOSE_S:.2f} s, assumed: the settings state no hand_close_s"


def close_on_ball(gripper: Gripper, now: Callable[[], float], wait: Wait, close_s: float, source: str) -> float:
    """Close `gripper` on the ball and wait until it holds it (module docstring), reading it every
    GRIP_STEP_S through `wait` (which lets the world's time pass, `now` reads it). `close_s` (s)
    and `source` (where it came from, `close_time_s`) bound the wait. Returns the measured close
    time (s, from the close command to the jaws settled). AppError in one line when the jaws did
    not settle on the ball within the bound (the hand is opened again)."""
    bound = GRIP_WAIT_FACTOR * close_s
    settle = JawsSettle(gripper.state(), closing=True)
    told = now()
    gripper.close()
    while True:
        state = gripper.state()
        if state.holding is not False and settle.feed(state):
            break
        if now() - told >= bound - 1e-9:
            gripper.open()
            raise AppError(
                f"the hand did not close on the ball within {bound:.2f} s ({GRIP_WAIT_FACTOR:g} x its close time, "
                f"{source}): put the ball between its jaws and throw again; a slower hand states its close time "
                "in the settings (hand_close_s)"
            )
        wait(GRIP_STEP_S)
    assert settle.settled_at is not None  # feed returned True
    wait(GRIP_SETTLE_S)  # the grip settles
    return max(0.0, settle.settled_at - told)
