"""A throw's boundary: whatever goes wrong while a throw runs, the arm ends at rest, the hand as the
throw's phase demands, and the operator is told why in one line.

`throw_boundary` wraps `wiithrow.app.throws.execution.execute_throw`. The throw's body says where
it is (`entering(phase)`); when anything is raised inside it (by the rig, the network, a driver,
the world, a Stop), the boundary ends the throw safely and raises `ThrowFailed` (an `AppError`: one
line, no traceback) whose `fault` says the phase, the cause and what the arm and the hand did.
The session records it as a failed throw (`ThrowRecord.failure`).

The rule, per phase (`Phase`):

| phase                     | from .. to                                          | the hand                     |
|---------------------------|-----------------------------------------------------|------------------------------|
| before it started         | the checks, the wait for the arm to rest           | not touched                  |
| closing the hand          | closing it on the ball, commanding the trajectory  | not touched (it holds the ball once closed) |
| in the wind-up            | the trajectory runs, the release time not reached; or a host-timed release the host got round to later than `release_timing.RELEASE_LATE_BOUND_S` after its time (`ReleaseTooLate`) | not opened: it keeps the ball (a scheduled open is cancelled) |
| at the release            | the wind-up reached the release time (the world's clock within `RELEASE_WINDOW_S` after it: the arm is at the validated release state), e.g. the hand's open command itself raised | told to open now, unless the clock has passed the release bound by then (then it keeps the ball): the release happens at the planned time |
| in flight                 | the hand was told to open .. the ball came down     | already letting go: not touched |
| while measuring           | the rig measures the landing marker                 | open: not touched            |

In every phase the arm is then told to brake (`Arm.stop`: Ruckig's brake within the velocity,
acceleration and jerk limits, replacing whatever runs, a follow-through included) and the boundary
lets time pass, reading only the arm (`Arm.is_moving`, never the rig nor the world's `advance`:
either may be what failed), until it rests (idle for `REST_HOLD_S`), or `BRAKE_TIMEOUT_S` passed
(the reason says so).

A hand that opens on its own clock (`robot.gripper.ScheduledOpen`, told `open_at(t_release)` with
the trajectory) decides the release itself: the boundary asks it to cancel (`cancel_open`); when it
did, the hand keeps the ball (the wind-up); when the release time had come on its clock, it let go
then, at the planned release, and the throw failed in flight; the boundary does not open it again.

Why the wind-up is not played on to its release: the ball goes where the plan says only when it
leaves at the planned state at the planned instant, and what times the release (the loop reading
the rig on the world's clock) is what just failed; an arm braking to rest with the ball in its
closed hand sends nothing anywhere, as a Stop does. Once the release time is reached, the arm is
where the release was validated, so the hand is opened then: that is the planned release. The
window lies within the release bound (`RELEASE_WINDOW_S` <= `RELEASE_LATE_BOUND_S`, 5 ms against
10 ms), and the boundary looks at the clock again just before it opens the hand: a release it
would make beyond the bound is not made (the ball is never released late, whoever opens the hand).

A ball that left the hand before the release (`wiithrow.app.worlds.grip.BallLost`: the wind-up's
watch of the hand saw it gone, `wiithrow.app.throws.hand_watch`, or a simulated world knows it) is
*lost in the wind-up*: there is nothing to release nor to keep. The wind-up stays the wind-up
(never "at the release"), a scheduled open is cancelled, the arm brakes to rest, and then the hand
is opened: braking with the jaws closed keeps whatever they still caught from being flung, and
the opened hand is ready for the next ball as after any throw, instead of looking like a hand that
kept one. Found after the release (the watch's last reading, a world's), the hand had opened at it.
The fault says so (`ThrowFault.ball_lost`, and how long before the release).

What is raised afterwards:

* a refusal before the throw started (an `AppError` of the checks: not validated, no hand, not
  from the arm's pose) as it is: nothing was thrown, nothing is recorded;
* any other `Exception`, a Stop included (`Cancelled`: "stopped by the operator"): `ThrowFailed`;
* `KeyboardInterrupt`: `ThrowInterrupted`, still a `KeyboardInterrupt` (Ctrl-C keeps its meaning),
  carrying the same `fault`; any other `BaseException` as it is, after the same safe stop.

The traceback of a fault goes to this module's logger at DEBUG level, never to the operator.
"""

from __future__ import annotations

import contextvars
import enum
import functools
import logging
from collections.abc import Callable
from dataclasses import dataclass
from typing import Concatenate, ParamSpec, TypeVar

from wiithrow.app.errors import AppError, expected_errors
from wiithrow.app.rig.waiting import Cancelled
from wiithrow.app.throws.release_timing import RELEASE_LATE_BOUND_S
from wiithrow.app.worlds import RigWorld
from wiithrow.app.worlds.grip import BallLost
from wiithrow.robot.gripper import ScheduledOpen

#: How late after the planned release time (s, world clock) a fault still counts as "at the
#: release": the hand is opened then (the arm is within this of its validated release state).
#: Within the release bound (`release_timing.RELEASE_LATE_BOUND_S`): such a release is on time.
RELEASE_WINDOW_S = 0.005
#: How long (s, world clock) the boundary waits for the braking arm to rest.
BRAKE_TIMEOUT_S = 3.0
#: The step (s) in which the boundary lets time pass while the arm brakes.
REST_STEP_S = 0.005
#: How long (s) the arm must stay idle to count as at rest: a velocity-mode servo without friction
#: feed-forward closes its last milliradians slowly, and a joint may creep again after a first still
#: reading (the MuJoCo arm's wrist does, for some 0.3 s after a hard brake with the ball).
REST_HOLD_S = 0.1
#: The longest cause (characters) a reason quotes.
CAUSE_CHARS = 200

_log = logging.getLogger(__name__)


class Phase(enum.Enum):
    """Where a throw's execution is (the values complete "the throw failed ...")."""

    CHECKS = "before it started"
    LOADING = "while closing the hand on the ball"
    WIND_UP = "in the wind-up"
    RELEASE = "at the release"
    FLIGHT = "in flight"
    MEASURING = "while measuring the landing"


#: What the hand did, per phase (see the module docstring; RELEASE is decided when it opens).
_HAND = {
    Phase.CHECKS: "was not used",
    Phase.LOADING: "was left as it was (closed on the ball if it held it)",
    Phase.WIND_UP: "kept the ball",
    Phase.FLIGHT: "had let the ball go at the release",
    Phase.MEASURING: "had let the ball go at the release",
}


@dataclass(frozen=True)
class ThrowFault:
    """How a throw ended after something was raised in it (times on the world's clock, s)."""

    phase: Phase
    cause: str  # one line: what was raised ("stopped by the operator" for a Stop)
    arm: str  # what the arm did ("braked to rest", ...)
    hand: str  # what the hand did
    t_fault: float  # when the boundary caught it
    t_rest: float | None  # when the arm was seen at rest (None: not seen)
    released_at: float | None  # when the hand was told to open (None: never)
    # the ball left the hand before the release (`grip.BallLost`): the throw was lost in the wind-up
    ball_lost: bool = False
    ball_lost_before_s: float | None = None  # how long before the release it was seen gone (s; None: unknown)

    @property
    def reason(self) -> str:
        """The one line the operator reads."""
        return f"the throw failed {self.phase.value}: {self.cause}; the arm {self.arm}, the hand {self.hand}"


class ThrowFailed(AppError):
    """A throw ended early, safely (see the module docstring); `fault` says how."""

    def __init__(self, fault: ThrowFault) -> None:
        super().__init__(fault.reason)
        self.fault = fault


class ThrowInterrupted(KeyboardInterrupt):
    """Ctrl-C during a throw, after the safe stop: still a KeyboardInterrupt; `fault` says how it ended."""

    def __init__(self, fault: ThrowFault) -> None:
        super().__init__(fault.reason)
        self.fault = fault


class _Boundary:
    """One running throw: its phase, and how to end it safely."""

    def __init__(self, world: RigWorld) -> None:
        self.world = world
        self.phase = Phase.CHECKS
        self.release_at: float | None = None  # the planned release time (world clock)
        self.released_at: float | None = None  # when the hand was told to open
        self.scheduled_open = False  # the hand was told to open at release_at on its own clock

    def stop_safely(self, exc: BaseException) -> ThrowFault | None:
        """Open the hand if this is the release, brake the arm to rest; the fault, or None for a
        refusal before the throw started (after braking all the same)."""
        clock = self.world.clock
        t_fault = clock.now()
        phase = self.phase
        lost = isinstance(exc, BallLost)  # nothing to release: the wind-up never becomes the release
        if phase is Phase.WIND_UP and not lost and self.release_at is not None and t_fault >= self.release_at - 1e-9:
            phase = Phase.RELEASE if t_fault <= self.release_at + RELEASE_WINDOW_S else Phase.WIND_UP
        if self.scheduled_open and phase in (Phase.WIND_UP, Phase.RELEASE):
            phase, hand = self._cancel_open(t_fault)
        else:
            hand = self._open_hand(t_fault) if phase is Phase.RELEASE else _HAND[phase]
        arm, t_rest = self._brake()
        if phase is Phase.CHECKS and isinstance(exc, AppError) and not isinstance(exc, Cancelled):
            return None
        if isinstance(exc, BallLost):
            hand = self._open_emptied_hand(phase, t_rest)
        fault = ThrowFault(
            phase,
            _cause(exc),
            arm,
            hand,
            t_fault,
            t_rest,
            self.released_at,
            ball_lost=lost,
            ball_lost_before_s=exc.before_release_s if isinstance(exc, BallLost) else None,
        )
        _log.debug("%s", fault.reason, exc_info=exc)
        return fault

    def _open_hand(self, now: float) -> str:
        gripper = self.world.gripper
        if gripper is None:  # (execute_throw refuses a world without a hand)
            return "is missing"
        release_at = self.release_at if self.release_at is not None else now
        late = self.world.clock.now() - release_at
        if late > RELEASE_LATE_BOUND_S:  # the boundary got to it too late itself: no late ball
            return (
                f"kept the ball (the release time had passed {1e3 * late:.0f} ms before, beyond the "
                f"{1e3 * RELEASE_LATE_BOUND_S:.0f} ms bound)"
            )
        try:
            gripper.open()
        except Exception as exc:
            return f"could not be told to open ({_cause(exc)}): it may still hold the ball"
        self.released_at = now
        return f"was told to open at the planned release time (+{1e3 * (now - release_at):.0f} ms)"

    def _open_emptied_hand(self, phase: Phase, t_rest: float | None) -> str:
        """The ball left the hand before the release: once the arm rests, the hand is opened (see
        the module docstring); what it did."""
        gripper = self.world.gripper
        if phase in (Phase.FLIGHT, Phase.MEASURING):
            return "had opened at the release, the ball already gone"
        if gripper is None or t_rest is None:
            return "was left closed (the ball had gone; the arm was not seen at rest)"
        try:
            gripper.open()
        except Exception as exc:
            return f"could not be told to open once the arm rested ({_cause(exc)})"
        return "was opened once the arm rested (the ball had already left it)"

    def _cancel_open(self, now: float) -> tuple[Phase, str]:
        """Take back the hand's scheduled open: (the phase the throw was really in, what the hand did)."""
        gripper = self.world.gripper
        if gripper is None or not isinstance(gripper, ScheduledOpen):
            return Phase.WIND_UP, _HAND[Phase.WIND_UP]
        try:
            cancelled = gripper.cancel_open()
        except Exception as exc:
            return Phase.WIND_UP, f"could not cancel its scheduled open ({_cause(exc)}): it may let the ball go"
        if cancelled or self.release_at is None or now < self.release_at - 1e-9:
            return Phase.WIND_UP, "kept the ball (its scheduled open was cancelled)" if cancelled else _HAND[
                Phase.WIND_UP
            ]
        self.released_at = self.release_at
        return Phase.FLIGHT, "had let the ball go at the planned release time, on its own clock"

    def _brake(self) -> tuple[str, float | None]:
        """Tell the arm to brake and let time pass until it rests: (what it did, when it rested)."""
        arm, clock = self.world.arm, self.world.clock
        start = clock.now()
        refused = ""
        try:
            arm.stop()
        except Exception as exc:  # a follow-through may still bring it to rest
            refused = f" (the brake command raised {_cause(exc)})"
        still_since: float | None = None
        while True:
            try:
                moving = arm.is_moving()
            except Exception as exc:
                return f"cannot be read ({_cause(exc)}){refused}: check that it stopped", None
            now = clock.now()
            still_since = None if moving else (now if still_since is None else still_since)
            if still_since is not None and now - still_since >= REST_HOLD_S - 1e-9:
                return f"braked to rest in {still_since - start:.2f} s{refused}", now
            if now - start >= BRAKE_TIMEOUT_S:
                return f"did not come to rest within {BRAKE_TIMEOUT_S:.0f} s{refused}: stop it at the arm", None
            clock.sleep(REST_STEP_S)


_CURRENT: contextvars.ContextVar[_Boundary | None] = contextvars.ContextVar("wiithrow_throw_boundary", default=None)


def entering(
    phase: Phase,
    *,
    release_at: float | None = None,
    scheduled_open: bool = False,
    released_at: float | None = None,
) -> None:
    """The running throw (in this thread) entered `phase`; `release_at`: its planned release time
    on the world's clock (given with the wind-up); `scheduled_open`: the hand is being told to open
    then on its own clock; `released_at`: when the host told the hand to open (given with the
    flight of a host-timed hand). Outside a throw's boundary, nothing."""
    boundary = _CURRENT.get()
    if boundary is not None:
        boundary.phase = phase
        if release_at is not None:
            boundary.release_at = float(release_at)
        if released_at is not None:
            boundary.released_at = float(released_at)
        boundary.scheduled_open = boundary.scheduled_open or scheduled_open


P = ParamSpec("P")
R = TypeVar("R")


def throw_boundary(execute: Callable[Concatenate[RigWorld, P], R]) -> Callable[Concatenate[RigWorld, P], R]:
    """Run `execute(world, ...)` (a throw) inside a boundary (see the module docstring)."""

    @functools.wraps(execute)
    def guarded(world: RigWorld, /, *args: P.args, **kwargs: P.kwargs) -> R:
        boundary = _Boundary(world)
        token = _CURRENT.set(boundary)
        try:
            return execute(world, *args, **kwargs)
        except BaseException as exc:
            fault = boundary.stop_safely(exc)
            if fault is None:
                raise
            if isinstance(exc, Exception):
                raise ThrowFailed(fault) from exc
            if isinstance(exc, KeyboardInterrupt):
                raise ThrowInterrupted(fault) from exc
            raise
        finally:
            _CURRENT.reset(token)

    return guarded


def _cause(exc: BaseException) -> str:
    """`exc` in one line: an expected error's message, else its type and message; a Stop and
    Ctrl-C by name."""
    if isinstance(exc, Cancelled):
        return "stopped by the operator"
    if isinstance(exc, KeyboardInterrupt):
        return "interrupted (Ctrl-C)"
    text = " ".join(str(exc).split())
    if not isinstance(exc, expected_errors()):
        text = f"{type(exc).__name__}: {text}" if text else type(exc).__name__
    return text if len(text) <= CAUSE_CHARS else text[: CAUSE_CHARS - 1] + "…"
