"""Joint-1 alignment: turn the arm until the target lies in the throw plane y = 0 of `link1`.

Owns the tracking part of the throwing task (the paper's "about 10 s"), for any `robot.Arm` with
its `ArmModel`, any calibrated `RigStream` (tracked markers in link1) and any clock:

    every period (10 ms, 100 Hz, on the clock): read the remotes; the target's tracked position
    p = (x, y, z) in link1 at the frame's time t_f gives its azimuth in base
        psi = q1(t_f) + atan2(y, x)          (link1 is base turned by q1 about z)
    with q1(t_f) the measured joint-1 angle interpolated at t_f; the joint-1 error is e = psi - q1_ref
    (q1_ref: the commanded reference now), and the wanted velocity
        v = psi_dot + sign(e) min(k_p |e|, sqrt(a_max |e|)),      |v| <= v_max
    (proportional near the goal, braking at half the acceleration limit far from it, capped at the
    velocity limit; also capped so that joint 1 can brake before its position limits). psi_dot,
    the target's own azimuth rate (the slope of psi over the last `rate_window_s`), removes the
    lag of a proportional law behind a moving target (omega / k_p: 7 cm at 2 m for 0.15 rad/s).

Commanding: re-planning a Ruckig move every 10 ms costs 2-6 ms per call for the PA-10 (measured:
`plan_move` samples the whole move at 1 kHz), so `Joint1Commander` streams short trajectories
instead (`arm.command_trajectory`, `horizon_s` long, 1 ms samples, built in well under a
millisecond): joint 1's acceleration follows a = clip((v - v_ref) / tau, +-a_max), changing at most
at the jerk limit, the velocity stays within +-v_max, the other joints hold still. Each new
trajectory starts from the previous one's state at that instant, so the reference is continuous;
if the loop stops sending, the arm finishes the last trajectory and brakes to rest by itself.

Phases: `acquire` (a short wait for the tracker to confirm a marker), `search` when no target is
in view (joint 1 sweeps back and forth with doubling amplitude up to its limits, at `search_speed`,
default the velocity limit: the common view is about 0.7 rad wide, so even at 1 rad/s the tracker
gets some 70 frames of a target passing through it),
`track` (the law above) and, with `hold_s`, done once the mean y of the last frames stays below
`tolerance_m` for `hold_s` with joint 1 nearly at rest (the target drifting by less than the
tolerance per second). A target not seen for `lost_timeout_s` while tracking stops the arm
with status "lost". `hold_s=None` tracks (a moving target) until `cancel` fires ("stopped") or
`timeout_s` passes ("timeout"). Every end stops the arm and waits until it is idle.
"""

from __future__ import annotations

import math
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from wiithrow.app.calibration.robot import Cancel, is_cancelled
from wiithrow.app.errors import AppError
from wiithrow.app.rig.stream import RigStream
from wiithrow.clock import Clock
from wiithrow.robot import Arm, ArmModel, JointTrajectory, StartMismatchError
from wiithrow.robot.limits import JointLimits
from wiithrow.vision.tracker import TrackedFrame

STATUSES = ("converged", "lost", "not_found", "timeout", "stopped")


@dataclass(frozen=True)
class AlignmentResult:
    """How the alignment ended.

    `status`: "converged" (|y| < tolerance for the hold time), "lost" (the target vanished while
    tracked), "not_found" (the search covered joint 1's range without seeing it), "timeout",
    "stopped" (cancelled; also the normal end of tracking without a hold time). `q1` (rad): joint 1
    at the end. `throw_xz` (m): the target's distance and height in the throw plane (x, z of
    link1); `position_link1`, `position_base` (m): its last measured position (mean of the last
    frames), NaN if never seen; `y_m`: its mean y then; `duration_s`: on the clock; `trace`:
    per-tick time, joint 1 and y (NaN when unseen) for plots.
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


def _clip(x: float, bound: float) -> float:
    """x limited to [-bound, bound] (plain floats: this runs for every 1 ms sample of a command)."""
    return min(max(float(x), -bound), bound)


class Joint1Commander:
    """Moves joint 1 at a wanted velocity by streaming short trajectories (module docstring).

    The other joints hold `q_hold`. `reference(t)` is the commanded (q1, v1, a1) at time t.
    """

    def __init__(
        self,
        arm: Arm,
        limits: JointLimits,
        clock: Clock,
        q_hold: NDArray[np.float64],
        *,
        horizon_s: float = 0.03,
        dt: float = 0.001,
        tau_s: float = 0.04,
        margin_rad: float = 0.02,
        retries: int = 2,
    ) -> None:
        self.arm, self.limits, self.clock = arm, limits, clock
        self.q_hold = np.array(q_hold, dtype=float)
        self.horizon, self.dt, self.tau, self.margin = horizon_s, dt, tau_s, margin_rad
        self.v_max = float(limits.velocity[0])
        self.a_max = float(limits.acceleration[0])
        self.j_max = float(limits.jerk[0])
        self.lo = float(limits.lower[0]) + margin_rad
        self.hi = float(limits.upper[0]) - margin_rad
        self._traj: JointTrajectory | None = None
        self._t0 = clock.now()
        self._state = (float(self.q_hold[0]), 0.0, 0.0)
        self.retries = int(retries)
        self.resyncs = 0  # commands rebuilt from the measured state after a start mismatch

    def reference(self, t: float | None = None) -> tuple[float, float, float]:
        """(q1, v1, a1) commanded at time t (default now); after the last trajectory's end, its end
        state (the arm brakes from there: `resync` takes the measured state again)."""
        if self._traj is None:
            return self._state
        t = self.clock.now() if t is None else t
        q, v, a = self._traj.sample(min(t - self._t0, self._traj.duration))
        return float(q[0]), float(v[0]), float(a[0])

    def expired(self) -> bool:
        return self._traj is not None and self.clock.now() - self._t0 > self._traj.duration + 1e-9

    def resync(self) -> None:
        """Restart the reference from the measured state (at the start, or after a gap)."""
        s = self.arm.state()
        self._traj = None
        self.q_hold = s.q.copy()
        self._state = (float(s.q[0]), float(np.clip(s.dq[0], -self.v_max, self.v_max)), 0.0)

    def brake_limit(self, q: float, v: float, v_want: float) -> float:
        """Cap a wanted velocity so that joint 1 can stop before its limits: braking at a_max / 2
        from v needs v^2 / a_max, and the velocity loop's lag (tau plus the jerk-limited rise of
        the acceleration, a_max / j_max) runs on at v meanwhile:
            v_want <= sqrt(a_max (room - |v| (tau + a_max / j_max)))."""
        room = (self.hi - q) if v_want > 0 else (q - self.lo)
        room -= abs(v) * (self.tau + self.a_max / self.j_max)
        return math.copysign(min(abs(v_want), math.sqrt(max(room, 0.0) * self.a_max)), v_want)

    def command(self, v_want: float) -> None:
        """Send a trajectory of `horizon_s` that brings joint 1's velocity towards `v_want`.

        If the arm refuses it because it no longer starts where the arm is (the loop was held up
        between reading the reference and commanding, e.g. by a loaded CPU, while joint 1 moved
        by more than the arm's start tolerance), the reference restarts from the measured state
        and the command is built again (at most `retries` times; then the error stands).
        """
        if self.expired():
            self.resync()
        for attempt in range(self.retries + 1):
            traj = self._build(v_want)
            try:
                self.arm.command_trajectory(traj)
            except StartMismatchError:
                if attempt == self.retries:
                    raise
                self.resync()
                self.resyncs += 1
                continue
            self._traj, self._t0 = traj, self.clock.now()
            return

    def _build(self, v_want: float) -> JointTrajectory:
        """The trajectory of `command`, from the reference now."""
        q, v, a = self.reference()
        n = max(2, round(self.horizon / self.dt) + 1)
        Q, V, A = np.empty(n), np.empty(n), np.empty(n)
        Q[0], V[0], A[0] = q, v, a
        for k in range(1, n):
            target = self.brake_limit(Q[k - 1], V[k - 1], _clip(v_want, self.v_max))
            a_goal = _clip((target - V[k - 1]) / self.tau, self.a_max)
            a_k = A[k - 1] + _clip(a_goal - A[k - 1], self.j_max * self.dt)
            v_k = _clip(V[k - 1] + a_k * self.dt, self.v_max)
            A[k] = (v_k - V[k - 1]) / self.dt
            V[k] = v_k
            Q[k] = Q[k - 1] + 0.5 * (V[k - 1] + v_k) * self.dt  # trapezoid: exact for constant acceleration
        positions = np.repeat(self.q_hold[None], n, axis=0)
        positions[:, 0] = np.clip(Q, self.limits.lower[0], self.limits.upper[0])
        velocities = np.zeros_like(positions)
        velocities[:, 0] = V
        accelerations = np.zeros_like(positions)
        accelerations[:, 0] = A
        return JointTrajectory(np.arange(n, dtype=np.float64) * self.dt, positions, velocities, accelerations)

    def stop(self) -> None:
        self.arm.stop()
        self._traj = None


class _History:
    """Measured joint-1 angles by time, to know where link1 pointed when a frame was taken."""

    def __init__(self, size: int = 200) -> None:
        self.t: deque[float] = deque(maxlen=size)
        self.q: deque[float] = deque(maxlen=size)

    def add(self, t: float, q1: float) -> None:
        self.t.append(t)
        self.q.append(q1)

    def at(self, t: float) -> float:
        return float(np.interp(t, np.array(self.t), np.array(self.q)))


def sweep_waypoints(q0: float, lower: float, upper: float, step: float) -> list[float]:
    """Joint-1 targets of the search: q0 + step, q0 - 2 step, q0 + 4 step, ... (a doubling sweep:
    it never travels more than about 9 times the distance to the target), clipped to the limits;
    a side whose limit was reached is not visited again. Ends when both limits are reached."""
    points: list[float] = []
    at_upper = at_lower = False
    amplitude, sign = step, 1.0
    while not (at_upper and at_lower):
        if sign > 0 and not at_upper:
            points.append(min(q0 + amplitude, upper))
            at_upper = points[-1] >= upper
        elif sign < 0 and not at_lower:
            points.append(max(q0 - amplitude, lower))
            at_lower = points[-1] <= lower
        amplitude, sign = 2.0 * amplitude, -sign
    return points


def align_joint1(
    arm: Arm,
    arm_model: ArmModel,
    rig: RigStream,
    clock: Clock,
    *,
    tolerance_m: float = 0.005,
    hold_s: float | None = 0.2,
    timeout_s: float = 30.0,
    gain: float = 4.0,
    period_s: float = 0.01,
    acquire_s: float = 0.15,
    lost_timeout_s: float = 0.3,
    search: bool = True,
    search_speed: float | None = None,
    search_step_rad: float = 0.6,
    average_frames: int = 5,
    rate_window_s: float = 0.3,
    cancel: Cancel = None,
    progress: Callable[[str, float], None] | None = None,
) -> AlignmentResult:
    """Turn joint 1 until the target (the tracked IR marker) lies in the plane y = 0 of link1.

    See the module docstring. `rig` must be calibrated in link1 (its tracker running) and see only
    the target. `progress(phase, y)` is called every period (y NaN when the target is unseen).
    Returns an AlignmentResult; raises AppError only for a rig without a calibration.
    """
    if rig.tracker is None:
        raise AppError("joint-1 alignment needs a calibrated rig (tracked markers in link1): calibrate first")
    t_start = clock.now()
    commander = Joint1Commander(arm, arm_model.limits, clock, arm.state().q)
    commander.resync()
    history = _History()
    recent: deque[NDArray[np.float64]] = deque(maxlen=average_frames)
    trace_t, trace_q, trace_y = [], [], []
    speed = min(search_speed or commander.v_max, commander.v_max)
    waypoints: list[float] | None = None
    target_id: int | None = None
    last_seen = -np.inf
    ever_seen = False
    psi = float("nan")
    psi_t: deque[float] = deque(maxlen=int(rate_window_s / period_s) + 1)
    psi_v: deque[float] = deque(maxlen=psi_t.maxlen)
    good_since: float | None = None
    phase = "acquire"
    status, message = "timeout", f"not aligned within {timeout_s:.1f} s"
    next_tick = clock.now()
    newest = rig.latest_tracked()
    # only frames taken from now on: frames still in the pipeline show the world before the call
    # (e.g. the target where it stood before it was moved)
    last_frame_t = max(newest.t if newest is not None else -np.inf, t_start)

    while True:
        next_tick += period_s
        clock.sleep(max(0.0, next_tick - clock.now()))
        rig.poll()
        # the frames tracked since the last tick (read from the stream's record, not from poll's
        # return value: another reader, the dashboard, may be polling the same stream)
        frames = rig.tracked_since(last_frame_t)
        if frames:
            last_frame_t = frames[-1].t
        now = clock.now()
        state = arm.state()
        history.add(state.t, float(state.q[0]))
        # -- measure: the target's position in the newest frames -------------------------------
        for frame in frames:
            p, target_id = _pick_target(frame, target_id, recent[-1] if recent else None)
            if p is not None:
                recent.append(p)
                last_seen, ever_seen = now, True
                psi = history.at(frame.t) + math.atan2(p[1], p[0])
                psi_t.append(frame.t)
                psi_v.append(psi)
        y_mean = (
            float(np.mean([p[1] for p in recent])) if recent and now - last_seen <= period_s * 1.5 else float("nan")
        )
        trace_t.append(now - t_start)
        trace_q.append(float(state.q[0]))
        trace_y.append(y_mean)
        # -- decide ------------------------------------------------------------------------------
        if is_cancelled(cancel):
            status, message = "stopped", "stopped by the operator" if hold_s is not None else "tracking stopped"
            break
        if now - t_start > timeout_s:
            break
        if ever_seen and now - last_seen > lost_timeout_s:
            status = "lost"
            message = f"the target was lost (not seen for {lost_timeout_s:.2f} s); the arm was stopped"
            break
        if not ever_seen:
            if phase == "acquire" and now - t_start >= acquire_s:
                if not search:
                    status, message = "not_found", "no target in view and the search is off"
                    break
                phase = "search"
                waypoints = sweep_waypoints(float(state.q[0]), commander.lo, commander.hi, search_step_rad)
            if phase == "search":
                q_ref = commander.reference()[0]
                while waypoints and abs(waypoints[0] - q_ref) < 1e-3:
                    waypoints.pop(0)
                if not waypoints:
                    status = "not_found"
                    message = "the search swept joint 1 over its whole range without seeing the target"
                    break
                e = waypoints[0] - q_ref
                commander.command(
                    math.copysign(min(speed, gain * abs(e) + 0.05, math.sqrt(commander.a_max * abs(e))), e)
                )
            elif phase == "acquire":
                commander.command(0.0)
        else:
            phase = "track"
            q_ref = commander.reference()[0]
            e = psi - q_ref
            v = _rate(psi_t, psi_v, rate_window_s) + math.copysign(
                min(gain * abs(e), math.sqrt(commander.a_max * abs(e))), e
            )
            commander.command(float(np.clip(v, -commander.v_max, commander.v_max)))
            # aligned and at rest: the target drifts in y by less than the tolerance per second
            distance = math.hypot(recent[-1][0], recent[-1][1])
            settled = abs(commander.reference()[1]) * distance < tolerance_m
            if hold_s is not None and np.isfinite(y_mean) and abs(y_mean) < tolerance_m and settled:
                good_since = now if good_since is None else good_since
                if now - good_since >= hold_s:
                    status, message = "converged", f"|y| < {1e3 * tolerance_m:.1f} mm for {hold_s:.2f} s"
                    break
            else:
                good_since = None
        if progress is not None:
            progress(phase, y_mean)

    commander.stop()
    _wait_idle(arm, rig, clock, period_s)
    q_end = arm.state().q
    p = np.mean(np.array(recent), axis=0) if recent else np.full(3, np.nan)
    base = arm_model.from_frame(p, q_end, "link1")
    return AlignmentResult(
        status,
        message,
        float(q_end[0]),
        np.array([p[0], p[2]]),
        p,
        base,
        float(p[1]),
        clock.now() - t_start,
        {"t": np.array(trace_t), "q1": np.array(trace_q), "y": np.array(trace_y)},
    )


def _rate(t: deque[float], psi: deque[float], window_s: float) -> float:
    """Least-squares slope of psi over time (rad/s), 0 until it spans half the window."""
    if len(t) < 5 or t[-1] - t[0] < 0.5 * window_s:
        return 0.0
    tt = np.array(t) - t[-1]
    pp = np.array(psi)
    tc = tt - tt.mean()
    return float(tc @ (pp - pp.mean()) / (tc @ tc))


def _pick_target(
    frame: TrackedFrame, target_id: int | None, last: NDArray[np.float64] | None, reacquire_m: float = 0.2
) -> tuple[NDArray[np.float64] | None, int | None]:
    """The target's measured position in this frame (None if not seen) and its track id: the
    locked id if visible, else a visible marker within `reacquire_m` of the last position (the
    tracker may have restarted the track), else, before any lock, the first visible marker."""
    visible = np.flatnonzero(frame.visible)
    if visible.size == 0:
        return None, target_id
    if target_id is not None:
        same = visible[frame.ids[visible] == target_id]
        if same.size:
            return frame.position[same[0]], target_id
    if last is not None:
        d = np.linalg.norm(frame.position[visible] - last, axis=1)
        i = int(np.argmin(d))
        if d[i] <= reacquire_m:
            return frame.position[visible[i]], int(frame.ids[visible[i]])
        return None, target_id
    return frame.position[visible[0]], int(frame.ids[visible[0]])


def _wait_idle(arm: Arm, rig: RigStream, clock: Clock, step: float, timeout_s: float = 5.0) -> None:
    """Keep reading the remotes while the arm brakes to rest."""
    end = clock.now() + timeout_s
    while arm.is_moving() and clock.now() < end:
        clock.sleep(step)
        rig.poll()
