"""Whether the target is a marker in this room: it must turn in the rig's view as joint 1 turns.

The rig is mounted on link1, which joint 1 turns about its axis z. A marker fixed in the room,
seen from link1 while joint 1 turns by dq1, turns by -dq1 about that axis: its azimuth in link1,
a = atan2(y, x), changes by -dq1. So the target's azimuth in the room (in base),

    psi = q1(t_f) + a,

with q1 the measured joint-1 angle at the frame's time t_f, stays where it is. A marker that is
not in the room does not: one a rogue publishes in link1, a reflection on the arm, a marker carried
on the arm turn with the rig (a stays, psi moves by the whole turn), and then the alignment's law
chases it to joint 1's limit. `RoomCheck` compares, over the last `ROOM_WINDOW_S`, the target's
turn in the rig's view (da) with joint 1's measured turn (dq1): once joint 1 turned by at least
`MIN_TURN_RAD`, the target's turn in the room, |da + dq1| = |dpsi|, may be at most

    bound = AZIMUTH_NOISE_RAD + FRAME_TIME_ERROR_S |dv1| + TURN_ERROR_FRACTION |dq1| + PERSON_RATE_RAD_S * span

(`dv1`: joint 1's change of speed over the window, rad/s; `span`: the seconds it covers): the
rig's azimuth noise, a frame's time against the arm's state's (an error of dt in it puts q1(t_f)
off by dt * dq1/dt, which cancels out of the turn unless the speed changed), the calibration's
error in proportion to the turn, and a target a person moves while the arm follows it. Beyond it
the target is refused (`refusal`) and the alignment brakes the arm.

What it cannot tell: a target that moves with joint 1 more slowly than a person carries a target
(`PERSON_RATE_RAD_S`) looks, in the rig's view, like a target a person walks around the arm; only
the source's authentication keeps such a source out. A target fixed in link1 drives joint 1 at
about its bearing off the throw plane over the loop's lag (some 15 ms), so one within some 7 mrad
of the plane turns joint 1 that slowly (3 mrad off: 0.2 rad/s in the kinematic world).
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass

#: The window (s) over which the target's turn is compared with joint 1's: long enough to hold
#: some 50 frames (100 Hz) and a turn of joint 1 well above the noise, short enough that a forged
#: target is refused before joint 1 turns far (at the PA-10's 1 rad/s, 0.5 rad in the window).
ROOM_WINDOW_S = 0.5
#: Joint 1's turn (rad) in the window before the check decides: 5.7 deg, five times the bound's
#: noise term, so that a target a person moves while the arm stands still is never judged by a
#: turn that did not happen.
MIN_TURN_RAD = 0.1
#: The rig's azimuth noise (rad) on a turn, each end of the window the mean of `END_FRAMES`
#: frames: a few mm of a wand-calibrated rig's noise at 0.5 m, the nearest target, is under 10
#: mrad; measured at most 0.7 mrad in the kinematic world (`tests/app/test_alignment_room.py`).
AZIMUTH_NOISE_RAD = 0.02
#: How far (s) a frame's time may be from the arm's time of the same instant (a camera's exposure
#: before its report, the state's read): the MuJoCo world's frames lag its arm's states by 17 ms
#: (fitted over its alignments: the turn in the room against joint 1's change of speed; at most
#: 27 mrad over 30 alignments of its three arms); twice that.
FRAME_TIME_ERROR_S = 0.035
#: The calibration's error in proportion to the turn: a calibration off by d (m) laterally sees a
#: target at range r turn by (1 +- d / r) of the true turn; 2 cm at 0.5 m, the nearest target, is 4 %.
TURN_ERROR_FRACTION = 0.05
#: How fast (rad/s) a person moves a target about joint 1's axis: walking it at 1 m/s around
#: the arm at 2 m, the middle of the throwing area (or dragging it in the dashboard); the
#: alignment follows such a target (`psi_dot`). A target moved faster while joint 1 turns is refused.
PERSON_RATE_RAD_S = 0.5
#: Frames averaged at each end of the window (the azimuth noise above assumes this many).
END_FRAMES = 3


def wrapped(angle: float) -> float:
    """An angle difference (rad) in [-pi, pi)."""
    return (angle + math.pi) % (2.0 * math.pi) - math.pi


def _speed(sightings: list[Sighting]) -> float:
    """Joint 1's mean speed (rad/s) over consecutive sightings (0 if they share one time)."""
    dt = sightings[-1].t - sightings[0].t
    return (sightings[-1].q1 - sightings[0].q1) / dt if dt > 0 else 0.0


@dataclass(frozen=True)
class Sighting:
    """The target in one frame: its time t_f (s), joint 1 measured then `q1` (rad), and its
    azimuth `azimuth` (rad) about joint 1's axis in link1, atan2(y, x)."""

    t: float
    q1: float
    azimuth: float


@dataclass(frozen=True)
class Turn:
    """Joint 1's turn and the target's over one window (rad; `span_s` in s)."""

    joint1: float
    in_view: float
    span_s: float
    speed_change: float  # joint 1's, rad/s, from the window's first frames to its last

    @property
    def in_room(self) -> float:
        """How far the target turned about joint 1's axis in the room: 0 for a fixed one."""
        return self.in_view + self.joint1

    def bound(self) -> float:
        """The most |in_room| a marker fixed in the room, or carried by a person, shows (module docstring)."""
        return (
            AZIMUTH_NOISE_RAD
            + FRAME_TIME_ERROR_S * abs(self.speed_change)
            + TURN_ERROR_FRACTION * abs(self.joint1)
            + PERSON_RATE_RAD_S * self.span_s
        )


class RoomCheck:
    """The target's sightings over the last `ROOM_WINDOW_S`, judged (see the module docstring)."""

    def __init__(self) -> None:
        self.sightings: deque[Sighting] = deque()
        self.ratio = float("nan")  # |in_room| / bound at the last `refusal`, NaN while undecided

    def add(self, sighting: Sighting) -> None:
        """Keep a sighting (in time order) and forget those older than the window."""
        self.sightings.append(sighting)
        while self.sightings and sighting.t - self.sightings[0].t > ROOM_WINDOW_S:
            self.sightings.popleft()

    def forget(self) -> None:
        """Start again (the target was lost, or another marker became the target)."""
        self.sightings.clear()

    def turn(self) -> Turn | None:
        """Joint 1's and the target's turn over the window (the means of `END_FRAMES` frames at
        each end), None before the window holds twice that many."""
        s = self.sightings
        if len(s) < 2 * END_FRAMES:
            return None
        first, last = list(s)[:END_FRAMES], list(s)[-END_FRAMES:]
        a0 = first[0].azimuth  # azimuths relative to one of them: no wrap inside a mean
        a_first = sum(wrapped(x.azimuth - a0) for x in first) / END_FRAMES
        a_last = sum(wrapped(x.azimuth - a0) for x in last) / END_FRAMES
        q_first = sum(x.q1 for x in first) / END_FRAMES
        q_last = sum(x.q1 for x in last) / END_FRAMES
        span = sum(x.t for x in last) / END_FRAMES - sum(x.t for x in first) / END_FRAMES
        return Turn(q_last - q_first, a_last - a_first, span, _speed(last) - _speed(first))

    def refusal(self) -> str | None:
        """Why the target is not a marker in this room (one line), None while it may be one."""
        turn = self.turn()
        self.ratio = float("nan")
        if turn is None or abs(turn.joint1) < MIN_TURN_RAD:
            return None
        self.ratio = abs(turn.in_room) / turn.bound()
        if self.ratio <= 1.0:
            return None
        return (
            f"not a marker in this room: it turned {math.degrees(turn.in_view):+.1f} deg in the rig's view "
            f"while joint 1 turned {math.degrees(turn.joint1):+.1f} deg in {turn.span_s:.2f} s "
            f"(a marker in the room turns by {math.degrees(-turn.joint1):+.1f} +- {math.degrees(turn.bound()):.1f} deg)"
        )
