"""Waiting while the rig keeps reading: time passing, an arm coming to rest, an operator's Stop.

Owns the one way everything (calibration, alignment, a throw, a figure's measurement, the tests)
lets time pass: on the operation's clock, in steps, reading the remotes after each step so that their
reports never pile up, and looking at the operation's `cancel` after each step.

* `Cancel`: what an operation is given to be stopped by: a `threading.Event`, a callable that
  returns True once it should stop, or None (never);
* `pump(clock, source, seconds)` / `pump_until(clock, source, t)`: let time pass, reading the
  marker source (`source.poll()`) after each step (`on_read` after each read, `on_step` after each
  step); raise `Cancelled` when `cancel` fires. What was
  tracked meanwhile is read from the source, the one way to read frames:
  `since = newest_t(source); pump(...); source.tracked_since(since)` (whoever else polled it);
* `wait_while_moving(arm, clock, rig)`: the same until the arm is idle (False on a timeout).

With a `SimClock`, sleeping advances simulated time, so the simulated world runs as fast as the
CPU allows, and a step before the rig's `quiet_until` (no report can be due, nothing to flush, no
listener) skips its read, which would do nothing; with the system clock the loop keeps up with the remotes' 100 reports per second.
`Cancelled` is a signal, not a message: each operation catches it, stops the arm and raises its
own error saying what was stopped and what was kept.
"""

from __future__ import annotations

import math
import threading
from collections.abc import Callable
from typing import Protocol

from wiithrow.app.errors import AppError
from wiithrow.clock import Clock, SimClock
from wiithrow.robot import Arm

Cancel = threading.Event | Callable[[], bool] | None

#: Time (s) below which two clock readings count as the same instant (float round-off).
EPS_S = 1e-12


class Cancelled(AppError):
    """The operation's `cancel` fired while it waited (see the module docstring)."""


class Reads(Protocol):
    """What a wait reads at every step: a marker source (`wiithrow.app.rig.source.MarkerSource`)."""

    def poll(self) -> None: ...


def is_cancelled(cancel: Cancel) -> bool:
    """True once `cancel` (an Event, a callable or None) says stop."""
    if cancel is None:
        return False
    if isinstance(cancel, threading.Event):
        return cancel.is_set()
    return bool(cancel())


def pump_until(
    clock: Clock,
    rig: Reads,
    t: float,
    *,
    step_s: float = 0.01,
    on_step: Callable[[], None] | None = None,
    on_read: Callable[[], None] | None = None,
    cancel: Cancel = None,
    read_when_late: bool = False,
) -> None:
    """Let the clock run to time `t` in steps of at most `step_s` (s), reading `rig` after each
    step, calling `on_read` after each read and `on_step` after each step. Raises `Cancelled`
    after the step in which `cancel` fired. `read_when_late`: read `rig` once even when `t` has
    passed already (a periodic loop that fell behind the system clock still reads every period).

    `on_read` is for whoever only takes what a read brought (frames, progress): on a simulated
    clock the reads that would bring nothing may be skipped, and `on_read` with them (`_quiet_of`);
    `on_step` runs at every step, so it keeps every read."""
    if read_when_late and clock.now() >= t - EPS_S:
        rig.poll()
        if on_read is not None:
            on_read()
        return
    quiet_of = _quiet_of(clock, rig, on_step, cancel)
    quiet = -math.inf  # before this clock time a read would do nothing (`_quiet_of`)
    while True:
        now = clock.now()
        if now >= t - EPS_S:
            return
        clock.sleep(min(step_s, t - now))
        if quiet_of is None or clock.now() >= quiet:
            rig.poll()
            if quiet_of is not None:
                quiet = quiet_of()
            if on_read is not None:
                on_read()
        if on_step is not None:
            on_step()
        if is_cancelled(cancel):
            raise Cancelled("cancelled")


def _quiet_of(
    clock: Clock, rig: Reads, on_step: Callable[[], None] | None, cancel: Cancel
) -> Callable[[], float] | None:
    """The rig's `quiet_until` (a clock time before which its `poll()` would read, track and tell
    nothing: `RigStream.quiet_until`) when a wait may skip those reads: on a simulated clock,
    where nothing else runs between two steps (no `on_step`, a `cancel` that is an Event or
    None), so the steps' reads that are skipped are exactly the ones that would have done nothing
    (the same frames, at the same times), and an `on_read` skipped with them would have found
    nothing new. None: read at every step."""
    if (
        not isinstance(clock, SimClock)
        or on_step is not None
        or not (cancel is None or isinstance(cancel, threading.Event))
    ):
        return None
    quiet_until: Callable[[], float] | None = getattr(rig, "quiet_until", None)
    return quiet_until


def pump(
    clock: Clock,
    rig: Reads,
    seconds: float,
    *,
    step_s: float = 0.01,
    on_step: Callable[[], None] | None = None,
    on_read: Callable[[], None] | None = None,
    cancel: Cancel = None,
) -> None:
    """`pump_until` the clock's now plus `seconds`."""
    pump_until(clock, rig, clock.now() + seconds, step_s=step_s, on_step=on_step, on_read=on_read, cancel=cancel)


def wait_while_moving(
    arm: Arm,
    clock: Clock,
    rig: Reads,
    *,
    timeout_s: float,
    step_s: float = 0.01,
    poll_step_s: float | None = None,
    cancel: Cancel = None,
) -> bool:
    """While the arm moves, let `step_s` pass at a time, reading the rig every `poll_step_s`
    (default `step_s`); True once the arm is idle, False when `timeout_s` passed first (the arm is
    left as it is: the caller decides). Raises `Cancelled`."""
    end = clock.now() + timeout_s
    while arm.is_moving():
        if clock.now() > end:
            return False
        pump(clock, rig, step_s, step_s=poll_step_s or step_s, cancel=cancel)
    return True
