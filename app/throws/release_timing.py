"""When a host-timed hand lets the ball go: on the world's clock, never later than a stated bound.

A hand that schedules its open (`robot.gripper.ScheduledOpen`) is told `open_at(t_release)` with
the trajectory and opens on its own clock; nothing here times it. Any other hand (*host-timed*)
is told `open()` by the thread that runs the throw, and this module owns that thread's wait from
the wind-up's start to the release (`release_host_timed`):

* **Nothing on the timing path waits on the rig or the network.** The throw's thread reads only
  the world's clock (and the operation's `cancel`, an Event or a callable that returns at once)
  until `t_release`, then opens the hand. It never calls the rig's `poll()`: a camera read that
  stalls (a slow USB read, a Zenoh flood draining under the rig's lock) would hold the release
  for as long as it stalls.
* **Frames do not pile up meanwhile.** On a system clock a reader thread (`rig_reader`) keeps
  reading the rig every `READ_STEP_S` during the wind-up (the rig's `poll` is serialised by its
  lock, so nothing else reads it twice at once); it starts no read within `QUIET_BEFORE_RELEASE_S`
  of the release (a read's Python work holds the interpreter's lock up to its switch interval,
  which the throw's thread may be waiting for just then), resumes after it, and is joined once
  the hand was told (`PeriodicReader.finish`: a read it was stuck in then is waited for at most
  `READER_JOIN_S`; what it raised is raised then). A read that raised before the release is
  raised by the throw's thread at its next step, so the wind-up ends at its boundary as before
  (the hand keeps the ball). On a `SimClock` nothing advances the clock but the throw's thread,
  which just advances it: the remotes' reports of the wind-up are produced on the next read, as
  after any wait that skipped its reads, their bounded buffers dropping the oldest.
* **The hand is watched meanwhile** (`wiithrow.app.throws.hand_watch`), off the timing path too:
  on a system clock by a second thread (`hand_watcher`, the same `PeriodicReader`, its reads ending
  `QUIET_BEFORE_RELEASE_S` before the release), whose finding (a lost ball) the throw's thread
  raises at its next step and which is joined after the release as the rig's; on a `SimClock` by
  the throw's thread between its steps, none within `QUIET_BEFORE_RELEASE_S` of the release.
* **The bound.** Just before `open()`, when the world's clock is already past
  `t_release + RELEASE_LATE_BOUND_S` (the thread woke late: a loaded host, a stalled clock),
  the hand is not opened: `ReleaseTooLate` is raised in the wind-up, and the throw's boundary
  (`wiithrow.app.throws.safe_stop`) ends it there: the hand keeps the ball, the arm brakes to
  rest, the reason says how late the host was. When `open()` itself returns beyond the bound (the
  call blocked: the host cannot tell when the jaws were told), or a hand that reports when it
  carried out its open (`robot.gripper.ReportsOpenTime`) reports a time beyond it, the ball has
  gone: the throw runs to its end and is recorded as a late release (`ThrowExecution.release_late_s`,
  `late_release_line`), which never labels a library (the learning library's join and a training
  run refuse it).

Why 10 ms: past its release time the arm decelerates in its follow-through, so a late release
sends the ball slower and lower. Over a 5 x 5 grid of the PA-10's trained area (release speeds
1.1-2.8 m/s; the planned trajectory played on, the ball flown with the planner's ballistics),
releasing 10 ms late moves the landing by at most 10 mm, 20 ms late by 10-34 mm, 50 ms late by
8-17 cm, 0.74 s late by 0.3-0.9 m. 10 ms keeps the cost within the 10 mm the kinematic world's
throws land from their plan (2 ms of release jitter); 20 ms would not. The boundary's "at the
release" window (`safe_stop.RELEASE_WINDOW_S`, 5 ms) lies within the bound, and the boundary
looks at the clock again before it opens a hand at the release: it opens none beyond the bound.
"""

from __future__ import annotations

import math
import threading
from collections.abc import Callable

from wiithrow.app.errors import AppError
from wiithrow.app.rig.waiting import Reads
from wiithrow.app.throws.hand_watch import HandWatch
from wiithrow.clock import Clock, SimClock
from wiithrow.robot.gripper import Gripper, ReportsOpenTime

#: How late (s, the world's clock) after its planned time a host-timed hand may be told to open
#: (see the module docstring: 10 ms late costs at most 10 mm of landing over the PA-10's trained area).
RELEASE_LATE_BOUND_S = 0.010
#: The step (s) in which the throw's thread lets the wind-up pass (it looks at `cancel` and at the
#: reader's error after each), and in which the reader thread reads the rig (the remotes report
#: every 10 ms).
READ_STEP_S = 0.01
#: The reader thread starts no read this long (s) before the release (two switch intervals of the
#: interpreter, 5 ms each by default): the throw's thread wakes then.
QUIET_BEFORE_RELEASE_S = 0.02
#: How long (s) the throw waits after the release for a read the reader thread is stuck in: a rig
#: whose read has not returned by then (the incident's stalls took 0.4 s) has stopped, and the
#: throw ends in flight (the arm brakes; the boundary reads only the arm).
READER_JOIN_S = 2.0
#: Two clock readings this close (s) are the same instant (float round-off).
_EPS_S = 1e-9


class ReleaseTooLate(AppError):
    """The host got round to a host-timed release later than RELEASE_LATE_BOUND_S after its time:
    the hand was not opened (the throw's boundary keeps the ball). `late_s`: how late (s)."""

    def __init__(self, late_s: float) -> None:
        super().__init__(
            f"the host got round to the release {1e3 * late_s:.0f} ms after its time, beyond the "
            f"{1e3 * RELEASE_LATE_BOUND_S:.0f} ms bound: the ball was kept rather than thrown late"
        )
        self.late_s = float(late_s)


def late_release_line(late_s: float) -> str:
    """A late release in one line (`ThrowExecution.release_late_s`, s): why it labels nothing."""
    return (
        f"late release: the hand opened {1e3 * late_s:.0f} ms after its time (bound {1e3 * RELEASE_LATE_BOUND_S:.0f} "
        "ms), so the ball did not fly the planned throw and its landing joins no library"
    )


def release_late_s(late_s: float) -> float | None:
    """`late_s` (s after the planned release) when it is beyond the bound, else None (on time)."""
    return float(late_s) if late_s > RELEASE_LATE_BOUND_S + _EPS_S else None


def reported_open_late_s(hand: object, t_release: float) -> float | None:
    """How late (s) a hand that reports when it carried out its open (`ReportsOpenTime`) says it
    did, after `t_release`; None when it does not report (or has not opened)."""
    if not isinstance(hand, ReportsOpenTime):
        return None
    t = hand.last_open_time()
    return None if t is None else float(t) - t_release


class PeriodicReader:
    """Calls `read()` every READ_STEP_S on a thread of its own (`name`) while a host-timed wind-up
    runs on a system clock (see the module docstring); starts no read in [`quiet_from`,
    `quiet_to`). What a read raises ends the reads and is raised by the throw's thread
    (`raise_error`, `finish`). `what`: the read in words, for the line of one that did not return."""

    def __init__(
        self,
        read: Callable[[], object],
        clock: Clock,
        quiet_from: float,
        quiet_to: float,
        *,
        name: str = "wiithrow-throw-reader",
        what: str = "the rig's read",
    ) -> None:
        self.read, self.clock, self.what = read, clock, what
        self.quiet_from, self.quiet_to = quiet_from, quiet_to
        self.reads = 0
        self.error: BaseException | None = None
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, name=name, daemon=True)

    def start(self) -> None:
        self._thread.start()

    def _run(self) -> None:
        while not self._stop.is_set():
            now = self.clock.now()
            if not self.quiet_from <= now < self.quiet_to:
                try:
                    self.read()
                except BaseException as exc:  # raised by the throw's thread (`raise_error`, `finish`)
                    self.error = exc
                    return
                self.reads += 1
            self._stop.wait(READ_STEP_S)

    def raise_error(self) -> None:
        """Raise what a read raised, if one did (in the throw's thread)."""
        if self.error is not None:
            raise self.error

    def stop(self) -> None:
        """Start no further read (never waits)."""
        self._stop.set()

    def finish(self) -> None:
        """Stop reading, wait for the read under way (at most READER_JOIN_S), and raise what a
        read raised; AppError when the read under way did not return in time."""
        self._stop.set()
        self._thread.join(READER_JOIN_S)
        if self._thread.is_alive():
            raise AppError(f"{self.what} did not return within {READER_JOIN_S:.0f} s after the release")
        self.raise_error()


def rig_reader(rig: Reads, clock: Clock, quiet_from: float, quiet_to: float) -> PeriodicReader:
    """The reader thread of the rig (`wiithrow-throw-reader`): `rig.poll()` every READ_STEP_S."""
    return PeriodicReader(rig.poll, clock, quiet_from, quiet_to, what="the rig's read (check the remotes)")


def hand_watcher(watch: HandWatch, clock: Clock, t_release: float) -> PeriodicReader:
    """The watcher thread of a host-timed hand (`wiithrow-hand-watch`): `watch.check()` every
    READ_STEP_S (`hand_watch.HAND_WATCH_STEP_S`) until QUIET_BEFORE_RELEASE_S before `t_release`."""
    return PeriodicReader(
        watch.check,
        clock,
        t_release - QUIET_BEFORE_RELEASE_S,
        math.inf,
        name="wiithrow-hand-watch",
        what="the hand's state read (check the hand)",
    )


def release_host_timed(
    clock: Clock,
    rig: Reads,
    hand: Gripper,
    t_release: float,
    check_cancel: Callable[[], None],
    watch: HandWatch | None = None,
) -> tuple[float, float, list[PeriodicReader]]:
    """Wait on `clock` until `t_release` and tell `hand` to open (see the module docstring).
    `check_cancel()` raises when the operation was stopped (after each step of the wind-up).
    `watch` reads the hand in the wind-up (`hand_watch`: on a system clock in a thread of its own,
    on a simulated one between the steps while the release is more than QUIET_BEFORE_RELEASE_S away).

    Returns (when `open()` was called and when it returned, on `clock`; the reader threads, the
    rig's and the hand's, still to be `finish`ed, none on a simulated clock). Raises `ReleaseTooLate`
    (the hand not opened) when the clock is past `t_release + RELEASE_LATE_BOUND_S` just before the
    open, and whatever the reader threads found (a read that raised, a lost ball) or `check_cancel`
    raised before the release."""
    readers: list[PeriodicReader] = []
    if not isinstance(clock, SimClock):
        readers.append(rig_reader(rig, clock, t_release - QUIET_BEFORE_RELEASE_S, t_release + RELEASE_LATE_BOUND_S))
        if watch is not None:
            readers.append(hand_watcher(watch, clock, t_release))
        for reader in readers:
            reader.start()
    try:
        while (now := clock.now()) < t_release - _EPS_S:
            check_cancel()
            for reader in readers:
                reader.raise_error()
            if watch is not None and not readers and t_release - now > QUIET_BEFORE_RELEASE_S:
                watch.check()
            clock.sleep(max(0.0, min(READ_STEP_S, t_release - clock.now())))
        told = clock.now()
        if told - t_release > RELEASE_LATE_BOUND_S + _EPS_S:
            raise ReleaseTooLate(told - t_release)
        hand.open()
        return told, clock.now(), readers
    except BaseException:
        for reader in readers:
            reader.stop()  # (a read under way ends by itself; the boundary reads only the arm)
        raise
