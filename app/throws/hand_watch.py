"""The hand watched through the wind-up: a ball that leaves it before the release stops the throw.

From the trajectory's start to the release the hand is told to stay closed on the ball. A
`HandWatch` reads it (`Gripper.state()`) and raises `wiithrow.app.worlds.grip.BallLost` when a
reading of the closed hand says the ball is gone:

* a hand that can tell (`holding` True or False) is believed: `holding` False is a lost ball;
* a hand that cannot (`holding` None) is judged by its jaws: an opening more than
  `OPENING_TOLERANCE` (of the stroke) away from the opening it held the ball at once the grip
  settled. Closed further, the jaws went through where the ball was; opened wider, they are off
  its width: either way nothing is gripped. A hand that reads the same opening on the ball as on
  nothing (the MuJoCo hand reads 0 on both) is watched only for jaws opened wider.

**The rate**: a reading every `HAND_WATCH_STEP_S` (10 ms, the step of the wind-up's own loop and of
the remotes' reports): a ball that slips is seen within a step and a read, and the arm brakes with
it gone rather than flinging the next 10 ms of its path.

**Off the release's timing path.** Who reads the hand depends on who times the release
(`wiithrow.app.throws.release_timing`):

* a hand that opens on its own clock (`ScheduledOpen`): the throw's thread, between its waits: a
  read that stalls delays nothing but the next reading (the hand opens by itself);
* a host-timed hand on a simulated clock: the throw's thread, between its steps, starting no read
  within `release_timing.QUIET_BEFORE_RELEASE_S` of the release (a read takes no simulated time);
* a host-timed hand on a system clock: a watcher thread (`wiithrow-hand-watch`, a
  `release_timing.PeriodicReader`), which starts no read within `QUIET_BEFORE_RELEASE_S` of the
  release; the throw's thread only looks at what it found, at its next step, and never waits for
  a read: a read that stalls or raises does not delay the release. After the release the throw
  waits for the read under way (at most `release_timing.READER_JOIN_S`) and raises what it found.

A read that raises is counted (`HandWatchSummary`), not raised: the watch goes on, and the throw
is not stopped by a hand whose state cannot be read once (the release must not depend on it). A
reading taken after the hand was told to open (its `command` "open") says nothing of the wind-up.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from wiithrow.app.worlds.grip import BallLost
from wiithrow.clock import Clock
from wiithrow.fault_lines import describe
from wiithrow.robot.gripper import Gripper, GripperState

#: How often (s) the hand is read in the wind-up (see the module docstring).
HAND_WATCH_STEP_S = 0.01
#: How far (a fraction of the stroke) the jaws of a hand that cannot tell whether it holds may move
#: from where they held the ball before it counts as gone: a ball shifting in a closed grip moves
#: the jaws by a few percent of the stroke (the MuJoCo hand: under 1 %, its ball shifting 8 mm in
#: a 1 N grip); a ball of a third of the stroke's width leaving them moves them by 15 % or more.
OPENING_TOLERANCE = 0.1


@dataclass(frozen=True)
class HandWatchSummary:
    """What the watch of one wind-up did: `reads` that returned, `failed` reads (raised), the
    longest read (s, the world's clock), the last failure in one line (None: none)."""

    reads: int
    failed: int
    longest_read_s: float
    last_failure: str | None


class HandWatch:
    """Reads `hand` in the wind-up of a throw whose release is at `t_release` (the world's clock),
    judging each reading against `held` (the hand's state once the grip settled). See the module
    docstring."""

    def __init__(self, hand: Gripper, clock: Clock, held: GripperState, t_release: float) -> None:
        self.hand, self.clock = hand, clock
        self.held_opening = float(held.opening)
        self.t_release = float(t_release)
        self.reads = 0
        self.failed = 0
        self.longest_read_s = 0.0
        self.last_failure: str | None = None

    def check(self) -> None:
        """Read the hand once; BallLost when the reading says the ball is gone."""
        start = self.clock.now()
        try:
            state = self.hand.state()
        except Exception as exc:  # counted; the watch goes on (module docstring)
            self.failed += 1
            self.last_failure = describe(exc)
            return
        finally:
            self.longest_read_s = max(self.longest_read_s, self.clock.now() - start)
        self.reads += 1
        if self.lost(state):
            raise BallLost(self.t_release - float(state.t))

    def lost(self, state: GripperState) -> bool:
        """Whether `state`, a reading of the hand told to stay closed, says the ball is gone."""
        if state.command != "closed":
            return False
        if state.holding is not None:
            return not state.holding
        opening = float(state.opening)
        return math.isfinite(opening) and abs(opening - self.held_opening) > OPENING_TOLERANCE

    def summary(self) -> HandWatchSummary:
        return HandWatchSummary(self.reads, self.failed, self.longest_read_s, self.last_failure)
