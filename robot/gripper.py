"""The gripper interface: what the rest of the system may ask of a hand that holds the ball, real or
simulated, and `SimulatedGripper`, a hand without physics.

`Gripper` is a `typing.Protocol`, like `wiithrow.robot.interface.Arm`: `open()` and `close()`
command the jaws and return at once; `state()` says what was commanded, how far the jaws are open
and, when the hand can tell, whether it holds something.

A scheduled release (`ScheduledOpen`, optional): `open_at(t)` tells the hand to open at time `t` of
its own clock (the world's), `cancel_open()` takes that back if `t` has not come yet. A hand that
has it opens on its own clock, as a real arm controller's IO synchronised to the trajectory does:
a host that gets round to the release late does not make the ball leave late. A hand without it
is opened by the host when the release time comes (`open()`; never later than a bound: a host
later than that keeps the ball, `wiithrow.app.throws.release_timing`); `schedules_open(hand)`
tells which. A driver for the real hand implements it (named in the settings' `gripper_driver`,
"module:factory"); the MuJoCo world's hand implements it (`wiithrow.app.worlds.mujoco.devices`),
and so does `SimulatedGripper` for the kinematic world.

When it opened (`ReportsOpenTime`, optional): `last_open_time()` says when, on its clock, the hand
carried out its last open command (a scheduled open when its time came, an `open()` when it took
it), before its latency; a throw whose hand reports a time later than its release bound is
recorded as a late release (`wiithrow.app.throws.release_timing`). `SimulatedGripper` and the
MuJoCo world's hand report it.

Timing. A command takes effect after a latency: the jaws start moving at

    t_move = t_command + latency + dt,     dt ~ N(0, jitter^2)  (clipped at -latency)

and take `stroke_s` to go from closed to open (or back). The ball leaves the hand when the jaws
start opening (t_move of an `open`): what a throw has to get right, and what the learning of the
throw library absorbs when it is late.
"""

from __future__ import annotations

import math
import threading
from dataclasses import dataclass
from typing import Literal, Protocol, runtime_checkable

import numpy as np

from wiithrow.robot.errors import RobotError
from wiithrow.robot.interface import Clock

__all__ = [
    "Gripper",
    "GripperCommand",
    "GripperState",
    "ReportsOpenTime",
    "ScheduledOpen",
    "SimulatedGripper",
    "schedules_open",
]

GripperCommand = Literal["open", "closed"]


@dataclass(frozen=True)
class GripperState:
    """One reading of the hand at time `t` (s, its clock): the last `command`, how far the jaws are
    `opening` (0 closed on nothing, 1 fully open; a hand closed on a ball reads in between), and
    `holding`: True or False when the hand can tell whether something is between its jaws, None
    when it cannot."""

    t: float
    command: GripperCommand
    opening: float
    holding: bool | None


@runtime_checkable
class Gripper(Protocol):
    """A two-jaw hand that holds the ball until it is opened."""

    def open(self) -> None:
        """Open the jaws (returns at once; they move after the hand's latency)."""
        ...

    def close(self) -> None:
        """Close the jaws (returns at once; on a ball they stop on it and hold it)."""
        ...

    def state(self) -> GripperState:
        """The hand now."""
        ...


@runtime_checkable
class ScheduledOpen(Protocol):
    """A hand that opens at a time it is given, on its own clock (see the module docstring)."""

    def open_at(self, t: float) -> None:
        """Open the jaws at time `t` (s, the hand's clock, the world's); a `t` already past opens
        now. Returns at once; replaces an earlier scheduled open. The jaws then move after the
        hand's latency, as after `open()`."""
        ...

    def cancel_open(self) -> bool:
        """Take back the scheduled open: True when it was cancelled before its time came (the hand
        keeps what it holds), False when there was none left to cancel (its time came: it opened)."""
        ...


@runtime_checkable
class ReportsOpenTime(Protocol):
    """A hand that says when it carried out its last open (see the module docstring)."""

    def last_open_time(self) -> float | None:
        """When (s, the hand's clock) it carried out its last open command, before its latency: a
        scheduled open when its time came, an `open()` when it took it; None when it has not
        opened since it was last told to close."""
        ...


def schedules_open(gripper: object) -> bool:
    """Whether `gripper` can open at a time it is given (`ScheduledOpen`), or only when told (`open()`)."""
    return isinstance(gripper, ScheduledOpen)


class SimulatedGripper:
    """A `Gripper` without physics, on an injected clock (see the module docstring).

    With a ball loaded (`load_ball()`, what the operator does) a `close()` moves the jaws onto it
    (opening 0.5; every move of the jaws takes `stroke_s`); it holds the ball (`holding`) from the instant they
    reach it until they start to open; `opened_at` is that instant, the ball's release (None until
    the jaws opened with the ball in them since the last `close()`). `latency_s`, `jitter_s`
    (standard deviation), `stroke_s` (closed to open) in seconds; `rng` draws the jitter: a close
    takes `latency_s + stroke_s`. It schedules opens (`ScheduledOpen`): a scheduled
    open takes effect at its time on the clock, however late anything reads the hand; and it says
    when it carried out its last open (`ReportsOpenTime`).

    A slip (`slip_at(t)`): at time `t` the ball leaves the closed jaws, as a grip too weak for the
    wind-up's acceleration lets it go; the jaws close on nothing from then on, the hand no longer
    holds, and `lost_at` says when (an open after it releases nothing).
    """

    def __init__(
        self,
        clock: Clock,
        *,
        latency_s: float = 0.0,
        jitter_s: float = 0.0,
        stroke_s: float = 0.02,
        rng: np.random.Generator | None = None,
    ) -> None:
        for name, value in (("latency_s", latency_s), ("jitter_s", jitter_s), ("stroke_s", stroke_s)):
            if not (math.isfinite(value) and value >= 0):
                raise RobotError(f"{name} must be >= 0, got {value}")
        self.clock = clock
        self.latency_s = float(latency_s)
        self.jitter_s = float(jitter_s)
        self.stroke_s = max(float(stroke_s), 1e-6)
        self._rng = rng if rng is not None else np.random.default_rng(0)
        self._lock = threading.Lock()
        self._command: GripperCommand = "open"
        self._moves_at = float("-inf")  # when the jaws start moving towards the command
        self._from = 1.0  # opening when they start
        self._ball = False  # a ball between the jaws (loaded, not yet released)
        self._opened_at: float | None = None  # when the jaws last started to open (the ball's release)
        self._open_due: float | None = None  # a scheduled open's time (the clock's), not yet come
        self._open_time: float | None = None  # when the last open command was carried out (`last_open_time`)
        self._slips_at: float | None = None  # an injected slip's time, not yet come (`slip_at`)
        self._lost_at: float | None = None  # when the ball slipped out of the closed jaws

    def _delay(self) -> float:
        dt = float(self._rng.normal(0.0, self.jitter_s)) if self.jitter_s > 0 else 0.0
        return max(0.0, self.latency_s + dt)

    def _opening(self, t: float) -> float:
        target = 1.0 if self._command == "open" else (0.5 if self._ball else 0.0)
        if t <= self._moves_at:
            return self._from
        frac = min(1.0, (t - self._moves_at) / self.stroke_s)
        return self._from + (target - self._from) * frac

    def load_ball(self) -> None:
        """Put a ball between the open jaws (the operator's part; `close()` then holds it)."""
        with self._lock:
            self._ball = True
            self._slips_at = self._lost_at = None

    def slip_at(self, t: float) -> None:
        """The ball will leave the closed jaws at time `t` (s, the clock's; see the class docstring)."""
        if not math.isfinite(t):
            raise RobotError(f"a slip needs a finite time, got {t}")
        with self._lock:
            self._slips_at = float(t)
            self._settle(self.clock.now())

    @property
    def lost_at(self) -> float | None:
        """When the ball slipped out of the closed jaws (`slip_at`), None when it did not."""
        with self._lock:
            self._settle(self.clock.now())
            return self._lost_at

    def _holds(self, now: float) -> bool:
        """The jaws are closed on the ball: commanded closed with a ball between them, and done
        moving onto it (every move takes `stroke_s`: their opening reached the ball's, 0.5)."""
        if self._command != "closed" or not self._ball or now < self._moves_at:
            return False
        return now >= self._moves_at + self.stroke_s - 1e-12

    @property
    def opened_at(self) -> float | None:
        """When the jaws last started to open with the ball in them (the ball's release), or None."""
        with self._lock:
            self._settle(self.clock.now())
            return self._opened_at

    def _settle(self, now: float) -> None:
        """Carry out a scheduled open and a slip whose times have come, at those times, in order."""
        for _ in range(2):
            due = [t for t in (self._open_due, self._slips_at) if t is not None and now >= t - 1e-12]
            if not due:
                return
            t = min(due)
            if t == self._slips_at:
                self._slips_at = None
                self._slip(t)
            else:
                self._open_due = None
                self._command_open(t)

    def _slip(self, t: float) -> None:
        """The ball leaves the jaws at `t` if they were closed on it; they close on nothing from there."""
        if self._command != "closed" or not self._ball:
            return
        self._from = self._opening(t)
        self._ball = False
        self._moves_at = max(self._moves_at, t)
        self._lost_at = t

    def _command_open(self, t: float) -> None:
        self._open_time = t
        self._from = self._opening(t)
        self._command = "open"
        self._moves_at = t + self._delay()
        if self._ball:
            self._opened_at = self._moves_at
            self._ball = False

    def open(self) -> None:
        with self._lock:
            now = self.clock.now()
            self._settle(now)
            self._open_due = None  # told to open now: a scheduled open has nothing left to do
            self._command_open(now)

    def open_at(self, t: float) -> None:
        if not math.isfinite(t):
            raise RobotError(f"a scheduled open needs a finite time, got {t}")
        with self._lock:
            now = self.clock.now()
            self._settle(now)
            self._open_due = max(float(t), now)
            self._settle(now)

    def cancel_open(self) -> bool:
        with self._lock:
            self._settle(self.clock.now())
            cancelled = self._open_due is not None
            self._open_due = None
            return cancelled

    def last_open_time(self) -> float | None:
        with self._lock:
            self._settle(self.clock.now())
            return self._open_time

    def close(self) -> None:
        with self._lock:
            now = self.clock.now()
            self._settle(now)
            self._open_due = None  # told to close: a scheduled open would drop what it closes on
            self._open_time = None
            self._opened_at = None  # a release is of the ball this close holds
            self._from = self._opening(now)
            self._command = "closed"
            self._moves_at = now + self._delay()

    def state(self) -> GripperState:
        with self._lock:
            now = self.clock.now()
            self._settle(now)
            return GripperState(now, self._command, self._opening(now), self._holds(now))
