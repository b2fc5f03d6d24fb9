"""Joint-1 alignment: turn the arm until the target lies in the throw plane y = 0 of `link1`.

Owns the tracking part of the throwing task (the paper's "about 10 s"), for any `robot.Arm` with
its `ArmModel`, any calibrated `MarkerSource` (tracked markers in link1) and any clock:

    every period (10 ms, 100 Hz, on the clock; `pump_until`, reading the source): measure the target's azimuth
    psi in base (`wiithrow.app.alignment.target`); the joint-1 error is e = psi - q1_ref (q1_ref:
    the commanded reference now), and the wanted velocity
        v = psi_dot + sign(e) min(k_p |e|, sqrt(a_max |e|)),      |v| <= v_max
    (proportional near the goal, braking at half the acceleration limit far from it, capped at the
    velocity limit; the commander also caps it so that joint 1 can brake before its position
    limits). psi_dot, the target's own azimuth rate, removes the lag of a proportional law behind a
    moving target (omega / k_p: 7 cm at 2 m for 0.15 rad/s). The velocity is streamed to the arm by
    `wiithrow.app.alignment.commander.Joint1Commander`.

Phases, one method each of `Joint1Aligner`: `acquire` (a short wait for the tracker to confirm a
marker), `search` when no target is in view (joint 1 sweeps back and forth with doubling
amplitude up to its limits, `wiithrow.app.alignment.search`, at `search_speed`, default the
velocity limit: the common view is about 0.7 rad wide, so even at 1 rad/s the tracker gets some
70 frames of a target passing through it), `track` (the law above) and, with `hold_s`, done once
the mean y of the last frames stays below `tolerance_m` for `hold_s` with joint 1 nearly at rest
(the target drifting by less than the tolerance per second). A target not seen for
`lost_timeout_s` while tracking stops the arm with status "lost". On markers from another host
(a source that `ReportsStaleness`: `RemoteRig`) every tick also asks the source whether its
markers may move the arm: no fresh frame for 0.1 s (the publisher stopped, its frames late or a
burst of old ones) or a frame of the pinned publisher that failed validation ends the alignment
at once with status "stale" and the source's reason (`wiithrow.app.network.marker_checks`): the
arm is told to brake within one tick (10 ms) of the staleness being decidable. Every tick also
checks that the target is a marker in this room (`wiithrow.app.alignment.room_check`): as joint 1
turns, a marker fixed in the room turns the other way in the rig's view (the rig is on link1); a
target that turns with the rig instead (forged, a reflection, a marker on the arm) ends the
alignment at once with status "refused" and the reason, the arm braking. `hold_s=None` tracks (a moving
target) until `cancel` fires ("stopped") or `timeout_s` passes ("timeout"). Every end stops the
arm and waits until it is idle.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from wiithrow.app.alignment.commander import Joint1Commander
from wiithrow.app.alignment.room_check import RoomCheck
from wiithrow.app.alignment.search import sweep_waypoints
from wiithrow.app.alignment.target import TargetEstimate
from wiithrow.app.errors import AppError
from wiithrow.app.network.marker_checks import ReportsStaleness
from wiithrow.app.rig.source import MarkerSource, newest_t
from wiithrow.app.rig.waiting import Cancel, is_cancelled, pump_until, wait_while_moving
from wiithrow.app.worlds.base import RigWorld
from wiithrow.clock import Clock
from wiithrow.robot import Arm, ArmModel

Progress = Callable[[str, float], None]


@dataclass(frozen=True)
class AlignmentResult:
    """How the alignment ended.

    `status`: "converged" (|y| < tolerance for the hold time), "lost" (the target vanished while
    tracked), "stale" (markers from another host stopped, turned stale or failed validation),
    "refused" (the target did not turn in the rig's view as joint 1 turned: not a marker in this
    room), "not_found" (the search covered joint 1's range without seeing it), "timeout",
    "stopped" (cancelled; also the normal end of tracking without a hold time). `q1` (rad): joint 1
    at the end. `throw_xz` (m): the target's distance and height in the throw plane (x, z of
    link1); `position_link1`, `position_base` (m): its last measured position (mean of the last
    frames; in base by joint 1's angle at those frames, `TargetEstimate.joint1`), NaN if never
    seen; `y_m`: its mean y then; `duration_s`: on the clock; `trace`:
    per-tick time, joint 1, y (NaN when unseen) and `room`, the target's turn in the room over
    the room check's bound (`wiithrow.app.alignment.room_check`; NaN while undecided, > 1 refused).
    """

    status: str
    message: str
    q1: float
    throw_xz: NDArray[np.float64]
    position_link1: NDArray[np.float64]
    position_base: NDArray[np.float64]
    y_m: float
    duration_s: float
    trace: dict[str, NDArray[np.float64]] = field(repr=False, default_factory=dict)

    @property
    def converged(self) -> bool:
        return self.status == "converged"


@dataclass(frozen=True)
class AlignmentOptions:
    """How the alignment runs (see the module docstring). Lengths in m, times in s, angles in rad."""

    tolerance_m: float = 0.005  # |y| at which the target counts as in the plane
    hold_s: float | None = 0.2  # how long it must stay there; None: track until cancelled
    timeout_s: float = 30.0
    gain: float = 4.0  # k_p, 1/s
    period_s: float = 0.01  # the loop's tick
    acquire_s: float = 0.15  # wait for the tracker before searching
    lost_timeout_s: float = 0.3
    search: bool = True
    search_speed: float | None = None  # rad/s; None: joint 1's velocity limit
    search_step_rad: float = 0.6  # the first amplitude of the sweep
    average_frames: int = 5  # positions averaged for the measurement
    rate_window_s: float = 0.3  # window of the azimuth rate psi_dot


@dataclass
class _End:
    status: str
    message: str


class Joint1Aligner:
    """One alignment run (see the module docstring); `run()` once."""

    def __init__(
        self,
        arm: Arm,
        arm_model: ArmModel,
        rig: MarkerSource,
        clock: Clock,
        options: AlignmentOptions,
        *,
        cancel: Cancel = None,
        progress: Progress | None = None,
    ) -> None:
        if not rig.calibrated:
            raise AppError("joint-1 alignment needs a calibrated rig (tracked markers in link1): calibrate first")
        self.arm, self.model, self.rig, self.clock = arm, arm_model, rig, clock
        self.options = o = options
        self.cancel, self.progress = cancel, progress
        self.t_start = clock.now()
        self.commander = Joint1Commander(arm, arm_model.limits, clock, arm.state().q)
        self.commander.resync()
        self.target = TargetEstimate(o.average_frames, o.rate_window_s, o.period_s)
        self.room = RoomCheck()
        self.not_in_room: str | None = None  # why the target is not a marker in this room
        self.speed = min(o.search_speed or self.commander.v_max, self.commander.v_max)
        self.phase = "acquire"
        self.waypoints: list[float] | None = None
        self.good_since: float | None = None
        self.trace: dict[str, list[float]] = {"t": [], "q1": [], "y": [], "room": []}
        self.next_tick = clock.now()
        self.q1_now = float(arm.state().q[0])
        # only frames taken from now on: frames still in the pipeline show the world before the call
        # (e.g. the target where it stood before it was moved)
        self.last_frame_t = max(newest_t(rig), self.t_start)

    def run(self) -> AlignmentResult:
        """Tick until an end (converged, lost, not found, timeout, stopped), then stop the arm."""
        while True:
            now, y_mean = self._measure()
            end = self._should_end(now) or self._act(now, y_mean)
            if end is not None:
                return self._finish(end)
            if self.progress is not None:
                self.progress(self.phase, y_mean)

    # -- each tick ---------------------------------------------------------------------------------

    def _measure(self) -> tuple[float, float]:
        """Let time run to the tick (reading the source), take the target from the frames tracked
        since the last tick (the source's record: another reader, the dashboard, may poll it too).
        Returns (now, mean y or NaN)."""
        self.next_tick += self.options.period_s
        pump_until(self.clock, self.rig, self.next_tick, step_s=self.options.period_s, read_when_late=True)
        frames = self.rig.tracked_since(self.last_frame_t)
        if frames:
            self.last_frame_t = frames[-1].t
        now = self.clock.now()
        state = self.arm.state()
        self.q1_now = float(state.q[0])
        self.target.joint.add(state.t, float(state.q[0]))
        for sighting in self.target.add(frames, now):
            self.room.add(sighting)
        self.not_in_room = self.room.refusal()
        y_mean = self.target.y_mean(now)
        self.trace["t"].append(now - self.t_start)
        self.trace["q1"].append(float(state.q[0]))
        self.trace["y"].append(y_mean)
        self.trace["room"].append(self.room.ratio)
        return now, y_mean

    def _should_end(self, now: float) -> _End | None:
        """Stop, stale markers, a target not in this room, timeout, or a target that was seen and is lost."""
        o = self.options
        if is_cancelled(self.cancel):
            return _End("stopped", "stopped by the operator" if o.hold_s is not None else "tracking stopped")
        if isinstance(self.rig, ReportsStaleness) and (stale := self.rig.stale_reason()) is not None:
            return _End("stale", f"{stale}: the arm was stopped")
        if self.not_in_room is not None:
            return _End("refused", f"{self.not_in_room}: the arm was stopped")
        if now - self.t_start > o.timeout_s:
            return _End("timeout", f"not aligned within {o.timeout_s:.1f} s")
        if self.target.ever_seen and now - self.target.last_seen > o.lost_timeout_s:
            return _End("lost", f"the target was lost (not seen for {o.lost_timeout_s:.2f} s); the arm was stopped")
        return None

    def _act(self, now: float, y_mean: float) -> _End | None:
        """Command joint 1 for the phase the alignment is in."""
        if self.target.ever_seen:
            self.phase = "track"
            return self._track(now, y_mean)
        if self.phase == "acquire" and now - self.t_start >= self.options.acquire_s:
            if not self.options.search:
                return _End("not_found", "no target in view and the search is off")
            self.phase = "search"
            c = self.commander
            self.waypoints = sweep_waypoints(self.q1_now, c.lo, c.hi, self.options.search_step_rad)
        if self.phase == "search":
            return self._search()
        self.commander.command(0.0)  # acquire: hold still while the tracker confirms
        return None

    def _search(self) -> _End | None:
        """Sweep towards the next waypoint (proportional, braking near it, at most `speed`)."""
        c = self.commander
        waypoints = self.waypoints or []
        q_ref = c.reference()[0]
        while waypoints and abs(waypoints[0] - q_ref) < 1e-3:
            waypoints.pop(0)
        if not waypoints:
            return _End("not_found", "the search swept joint 1 over its whole range without seeing the target")
        e = waypoints[0] - q_ref
        c.command(math.copysign(min(self.speed, self.options.gain * abs(e) + 0.05, math.sqrt(c.a_max * abs(e))), e))
        return None

    def _track(self, now: float, y_mean: float) -> _End | None:
        """The law of the module docstring; converged once |y| stays small with joint 1 at rest."""
        o, c = self.options, self.commander
        q_ref = c.reference()[0]
        e = self.target.psi - q_ref
        v = self.target.rate() + math.copysign(min(o.gain * abs(e), math.sqrt(c.a_max * abs(e))), e)
        c.command(float(np.clip(v, -c.v_max, c.v_max)))
        # aligned and at rest: the target drifts in y by less than the tolerance per second
        settled = abs(c.reference()[1]) * self.target.distance() < o.tolerance_m
        if o.hold_s is not None and np.isfinite(y_mean) and abs(y_mean) < o.tolerance_m and settled:
            self.good_since = now if self.good_since is None else self.good_since
            if now - self.good_since >= o.hold_s:
                return _End("converged", f"|y| < {1e3 * o.tolerance_m:.1f} mm for {o.hold_s:.2f} s")
        else:
            self.good_since = None
        return None

    # -- the end -----------------------------------------------------------------------------------

    def _finish(self, end: _End) -> AlignmentResult:
        """Stop the arm, wait until it rests (reading the rig), report."""
        self.commander.stop()
        wait_while_moving(self.arm, self.clock, self.rig, timeout_s=5.0, step_s=self.options.period_s)
        q_end = self.arm.state().q
        p = self.target.position()
        at = q_end.copy()  # link1 where the positions were measured: joint 1 then, the rest now (at rest)
        if np.isfinite(self.target.joint1()):
            at[0] = self.target.joint1()
        base = self.model.from_frame(p, at, "link1")
        return AlignmentResult(
            end.status,
            end.message,
            float(q_end[0]),
            np.array([p[0], p[2]]),
            p,
            base,
            float(p[1]),
            self.clock.now() - self.t_start,
            {key: np.array(values) for key, values in self.trace.items()},
        )


def align_joint1(
    world: RigWorld,
    options: AlignmentOptions | None = None,
    *,
    cancel: Cancel = None,
    progress: Progress | None = None,
) -> AlignmentResult:
    """Turn joint 1 of `world`'s arm until the target (the tracked IR marker) lies in the plane
    y = 0 of link1.

    See the module docstring; `options` default to `AlignmentOptions()`. The world's rig must be
    calibrated in link1 (its tracker running) and see only the target. `progress(phase, y)` is
    called every period (y NaN when the target is unseen). Returns an AlignmentResult; raises
    AppError only for a rig without a calibration.
    """
    aligner = Joint1Aligner(
        world.arm,
        world.arm_model,
        world.rig,
        world.clock,
        options if options is not None else AlignmentOptions(),
        cancel=cancel,
        progress=progress,
    )
    return aligner.run()
