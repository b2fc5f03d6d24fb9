"""What one dashboard refresh draws, read from the running system in one place.

Owns `LiveState` and `read_live_state(session)`: the session's snapshot, the arm's measured joint
state and the placements the scene needs (link1, where the ball sits in the hand), the rig's
tracked markers (in `base`) and every camera's latest dots, the simulated target. Everything is
read through the public API of the session and of the world it exposes; nothing here computes
what the session should (no tracking, no planning).

Owns `RigReading` and `read_rig` too: the rig's newest tracked frame and camera frames, read only
when the rig's lock is free at once. While the rig polls (it holds the lock while it reads, tracks
and tells its consumers), a refresh draws what the previous one read instead of waiting: a
refresh that waited would wake on the lock's release, the very moment the rig's consumer threads
(the publisher's) want the interpreter lock, and take it from them for the rest of its drawing.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from wiithrow.app.rig.source import MarkerSource
from wiithrow.app.session import Session, SessionSnapshot
from wiithrow.fault_lines import describe
from wiithrow.vision.tracked_frame import TrackedFrame
from wiithrow.vision.wiimote.frames import IRFrame

#: Tracked markers or camera frames older than this (s) are not drawn as "now".
STALE_S = 0.25


@dataclass(frozen=True)
class LiveState:
    """The running system at one instant (positions in `base`, m; angles rad; pixels px)."""

    t: float  # the world's clock
    q: NDArray[np.float64]  # (nq,) measured joints
    link1: NDArray[np.float64]  # (4, 4) placement of link1 in base
    hand_ball: NDArray[np.float64]  # (3,) where the ball sits in the hand (the `ball` frame)
    marker_ids: NDArray[np.int64]  # (M,) visible tracked markers
    markers: NDArray[np.float64]  # (M, 3) their positions
    dots: NDArray[np.float64]  # (C, 4, 2) each camera's latest dots, NaN where none
    camera_fresh: NDArray[np.bool_]  # (C,) the camera sent a frame within STALE_S
    target: NDArray[np.float64]  # (3,) the simulated target, NaN while unlit
    session: SessionSnapshot
    ball: NDArray[np.float64] | None = None  # (3,) the ball now, where the world knows it (MuJoCo)
    hand_opening: float | None = None  # the gripper's jaws, 0 closed - 1 open (None: no gripper)
    hand_holding: bool | None = None  # whether the gripper holds the ball (None: it cannot tell)
    arm_fault: str | None = None  # why the arm's state could not be read (q is then the last known)

    @property
    def calibrated(self) -> bool:
        return self.session.calibration is not None


@dataclass(frozen=True)
class RigReading:
    """What a refresh read of the rig: its newest tracked frame and each camera's newest frame."""

    tracked: TrackedFrame | None = None
    frames: list[IRFrame | None] = field(default_factory=list)
    fresh: bool = True  # read now (False: the rig was polling, this is the previous reading)


def read_rig(rig: MarkerSource, previous: RigReading | None) -> RigReading:
    """The rig's newest frames if its lock is free now, else `previous` (see the module docstring);
    the first reading (no `previous`) waits for the lock."""
    if not rig.lock.acquire(blocking=previous is None):
        return RigReading(previous.tracked, previous.frames, fresh=False) if previous is not None else RigReading()
    try:
        return RigReading(rig.latest_tracked(), rig.latest)  # the lock is re-entrant: no second wait
    finally:
        rig.lock.release()


def read_live_state(
    session: Session, rig_reading: RigReading | None = None, previous: LiveState | None = None
) -> LiveState:
    """Read everything a refresh draws (see the module docstring); `rig_reading`: the rig's frames
    as `read_rig` gave them (default: read now, waiting for the rig's lock). A driver that raises
    (the arm's or the hand's state, the world's ball or target) does not stop the reading: the arm
    keeps `previous`'s joints (its zero pose at first) with `arm_fault` saying why, the hand and the
    ball are unknown (None), the target unlit (NaN); the rig's markers are read as always."""
    snapshot = session.snapshot()
    world = session.world
    reading = rig_reading if rig_reading is not None else read_rig(world.rig, None)
    now = world.clock.now()
    model = world.arm_model
    arm_fault: str | None = None
    try:
        q = np.asarray(world.arm.state().q, dtype=float)
    except Exception as exc:  # a driver's fault: the last known pose, said to be so
        arm_fault = describe(exc)
        q = previous.q if previous is not None else np.zeros(model.nq)
    link1 = model.frame_placement(q, "link1")
    hand_ball = model.frame_placement(q, "ball")[:3, 3]

    ids = np.zeros(0, dtype=np.int64)
    markers = np.zeros((0, 3))
    tracked = reading.tracked
    if tracked is not None and now - tracked.t <= STALE_S and len(tracked):
        seen = np.asarray(tracked.visible, dtype=bool)
        if seen.any():
            ids = np.asarray(tracked.ids)[seen].astype(np.int64)
            markers = model.from_frame(np.asarray(tracked.position)[seen], q, "link1")

    frames = reading.frames
    dots = np.full((len(frames), 4, 2), np.nan)
    fresh = np.zeros(len(frames), dtype=bool)
    for c, frame in enumerate(frames):
        if frame is not None and now - frame.t <= STALE_S:
            dots[c] = frame.dots
            fresh[c] = True

    try:
        target = world.source_position_base("target", q)
    except Exception:  # (the world cannot say now: drawn unlit)
        target = np.full(3, np.nan)
    try:
        ball = world.ball_position()
    except Exception:
        ball = None
    opening: float | None = None
    holding: bool | None = None
    if world.gripper is not None:
        try:
            hand = world.gripper.state()
            opening, holding = float(hand.opening), hand.holding
        except Exception:  # unknown, as for a hand that cannot tell
            pass
    return LiveState(
        now, q, link1, hand_ball, ids, markers, dots, fresh, target, snapshot, ball, opening, holding, arm_fault
    )
