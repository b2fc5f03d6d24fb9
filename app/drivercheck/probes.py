"""The measurements of `wiithrow check-driver`: each probe drives the arm (or the hand) through its
interface only (`wiithrow.robot.interface.Arm`, `wiithrow.robot.gripper.Gripper`), reads it every
`bounds.POLL_S` on the clock the driver was given, and judges what it measured against
`wiithrow.app.drivercheck.bounds`:

* `probe_state`: the arm at rest, `state()` read every `STATE_POLL_S` for `STATE_PROBE_S`
  (often enough that the reads do not limit what is measured): the driver's sample rate (1 / the
  median step of the timestamp between new samples; a host too busy to read every period still
  sees whole periods), the new samples seen per second, the largest gap between them, and the age
  of each read (clock now - its t);
* `probe_following`: a validated trajectory commanded at 1 kHz (`command_trajectory`), each new
  state compared with the command at its own timestamp: the worst joint's RMS and largest error,
  and the lag, the shift tau that minimises the RMS of q(t) - q_cmd(t - tau) over the moving
  joints (searched every 0.5 ms in +-`LAG_SEARCH_S`, refined by a parabola through the best three),
  over the whole motion or the window around a throw's release;
* `probe_limits`: `command_position` beyond each joint's upper and lower limit must raise
  `LimitError` (the driver's layer: the Arm contract) and move nothing; a trajectory beyond a
  limit never reaches a driver, the host's validator refuses it (that layer is checked too);
* `probe_stop`: Stop during a move: the time from `stop()` until every joint rests (and stays at
  rest), against the time the limits need (Ruckig's brake from the commanded state at Stop); the
  rest position against where that brake ends; every joint within its limits throughout;
* the hand's probe is `hand_probe.probe_hand`.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from wiithrow.app.drivercheck import bounds, motions
from wiithrow.app.drivercheck.host import HOST_LATE_S, host_lateness, host_mark
from wiithrow.app.drivercheck.report import CheckResult, judged, not_run
from wiithrow.clock import Clock
from wiithrow.robot import Arm, ArmModel, JointTrajectory, LimitError, plan_stop
from wiithrow.throwing import Ball, ThrowingError
from wiithrow.throwing.validator import validate


@dataclass(frozen=True)
class Samples:
    """States read from the arm: `read_at` (the clock when read), `t`, `q`, `dq` (the states),
    `span` (how long each read took, s; None where not measured)."""

    read_at: NDArray[np.float64]
    t: NDArray[np.float64]
    q: NDArray[np.float64]
    dq: NDArray[np.float64]
    span: NDArray[np.float64] | None = None

    def _keep(self, keep: NDArray[np.bool_]) -> Samples:
        span = None if self.span is None else self.span[keep]
        return Samples(self.read_at[keep], self.t[keep], self.q[keep], self.dq[keep], span)

    def new(self) -> Samples:
        """Only the reads that gave a new sample (a timestamp later than every one before it)."""
        if self.t.size == 0:
            return self
        return self._keep(np.concatenate([[True], self.t[1:] > np.maximum.accumulate(self.t)[:-1]]))

    def after(self, t0: float) -> Samples:
        return self._keep(self.t >= t0)


@dataclass(frozen=True)
class Recording:
    """What a probe read: its `samples`, and the trajectory it commanded at `t0` (None at rest),
    kept for the checks that judge the state itself (`plausibility`)."""

    samples: Samples
    traj: JointTrajectory | None
    t0: float


def record(arm: Arm, clock: Clock, duration: float, poll_s: float = bounds.POLL_S) -> Samples:
    """Read `arm.state()` every `poll_s` for `duration` s of `clock`."""
    read_at, t, q, dq, span = [], [], [], [], []
    end = clock.now() + duration
    while True:
        asked = clock.now()
        s = arm.state()
        now = clock.now()
        read_at.append(now)
        span.append(now - asked)
        t.append(float(s.t))
        q.append(np.array(s.q, dtype=float))
        dq.append(np.array(s.dq, dtype=float))
        if now >= end:
            break
        clock.sleep(min(poll_s, end - now))
    return Samples(np.array(read_at), np.array(t), np.array(q), np.array(dq), np.array(span))


def command(arm: Arm, clock: Clock, traj: JointTrajectory) -> float:
    """Command `traj`; returns its start on the clock: the call (the Arm contract: "starting now";
    whatever the driver spends before the motion starts is its lag)."""
    return timed_command(arm, clock, traj)[0]


def timed_command(arm: Arm, clock: Clock, traj: JointTrajectory) -> tuple[float, float]:
    """Command `traj`; (its start on the clock, how long the call took, s): a host that stalls the
    check's thread in the call makes the motion start later than the start says."""
    start = clock.now()
    arm.command_trajectory(traj)
    return start, clock.now() - start


# ----- the state ---------------------------------------------------------------------------------

#: The sample period is measured on at least this many steps the host read on time (a driver
#: that samples at 10 Hz, the slowest the check must catch, gives 5 in the probe's 0.5 s).
PACED_STEPS_MIN = 3
#: A read is on time when `state()` returned within this (s) of being called: its state's age is
#: known to within it. The ages are judged on at least this many reads on time.
READ_SPAN_MAX_S = 0.001
READS_ON_TIME_MIN = 100


def sample_period(samples: Samples) -> tuple[float, int]:
    """The driver's sample period (s) from its timestamps, and how many steps it was measured on.

    The step of the timestamp between two consecutive new samples is the driver's period when the
    host read the arm often in between (no gap between its reads more than half the step): it then
    found each new sample as it came. A step over which the host did not read (a thread woken
    late) is the host's gap, not the driver's period. The median of the steps read on time, at
    least `PACED_STEPS_MIN` of them; else the median of all the steps, and 0."""
    new_at = np.flatnonzero(np.concatenate([[True], samples.t[1:] > np.maximum.accumulate(samples.t)[:-1]]))
    if new_at.size < 2:
        return float("inf"), 0
    steps = np.diff(samples.t[new_at])
    gaps = np.diff(samples.read_at)[: new_at[-1]]  # gaps[i]: before read i + 1, up to the last new sample
    widest = np.maximum.reduceat(gaps, new_at[:-1])  # the widest gap between the reads of each step
    on_time = widest <= 0.5 * steps
    if int(on_time.sum()) >= PACED_STEPS_MIN:
        return float(np.median(steps[on_time])), int(on_time.sum())
    return float(np.median(steps)), 0


def probe_state(arm: Arm, clock: Clock, keep: list[Recording] | None = None) -> CheckResult:
    """The state's rate and latency, the arm at rest (module docstring); the reads go to `keep`."""
    mark = host_mark(clock)
    samples = record(arm, clock, bounds.STATE_PROBE_S, bounds.STATE_POLL_S)
    lateness = host_lateness(clock, mark)
    if keep is not None:
        keep.append(Recording(samples, None, float(samples.read_at[0])))
    # a state's age is known to within its read's span: judged on the reads the host made on time
    on_time = samples.span <= READ_SPAN_MAX_S if samples.span is not None else np.ones(samples.t.size, bool)
    timed = int(on_time.sum()) >= READS_ON_TIME_MIN
    age = (samples.read_at - samples.t)[on_time] if timed else samples.read_at - samples.t
    new = samples.new()
    span = float(samples.read_at[-1] - samples.read_at[0])
    seen = (new.t.size - 1) / span if span > 0 else 0.0
    gap = float(np.max(np.diff(new.read_at))) if new.t.size > 1 else span
    period, paced = sample_period(samples)
    rate = 1.0 / period if period > 0 else float("inf")
    figures: dict[str, Any] = {
        "sample_rate_hz": rate,
        "sample_period_s": period,
        "new_samples_per_s": seen,
        "largest_gap_s": gap,
        "age_median_s": float(np.median(age)),
        "age_p95_s": float(np.percentile(age, 95)),
        "age_min_s": float(np.min(age)),
        "reads": int(samples.t.size),
        "new_samples": int(new.t.size),
        "steps_read_on_time": int(paced),
        "reads_on_time": int(on_time.sum()),
    }
    limits = {
        "sample_rate_hz": {"min": bounds.STATE_RATE_MIN_HZ},
        "age_median_s": {"max": bounds.STATE_AGE_MEDIAN_MAX_S},
        "age_p95_s": {"max": bounds.STATE_AGE_P95_MAX_S},
        "age_min_s": {"min": bounds.STATE_AGE_MIN_S},
    }
    failures = []
    stale = rate < bounds.STATE_RATE_MIN_HZ
    if stale:
        failures.append(
            f"stale state: a new sample every {1e3 * period:.0f} ms ({rate:.0f} Hz < {bounds.STATE_RATE_MIN_HZ:.0f} Hz; "
            f"{samples.t.size} reads gave {new.t.size} samples, the same one for up to {1e3 * gap:.0f} ms)"
        )
    if figures["age_median_s"] > bounds.STATE_AGE_MEDIAN_MAX_S:
        failures.append(
            f"old state: median age {1e3 * figures['age_median_s']:.1f} ms > {1e3 * bounds.STATE_AGE_MEDIAN_MAX_S:.0f} ms"
        )
    if figures["age_p95_s"] > bounds.STATE_AGE_P95_MAX_S:
        failures.append(
            f"old state: 95th percentile age {1e3 * figures['age_p95_s']:.1f} ms > {1e3 * bounds.STATE_AGE_P95_MAX_S:.0f} ms"
        )
    aged = len(failures) > int(stale)
    future = figures["age_min_s"] < bounds.STATE_AGE_MIN_S
    if future:
        failures.append(
            f"a state {-1e3 * figures['age_min_s']:.1f} ms in the future: its timestamps are not on the clock the "
            "driver was given"
        )
    # the host's lateness explains a rate it read on no step on time, and an age it read too few
    # states on time to judge by
    read_gap = float(np.median(np.diff(samples.read_at))) if samples.t.size > 1 else span
    figures["read_gap_median_s"] = read_gap
    late = lateness is not None and lateness.late
    if failures and late and not future and (not paced or not stale) and (not timed or not aged):
        figures["host_late"] = (
            f"it read the arm every {1e3 * read_gap:.1f} ms (median; {samples.t.size} reads in {span:.2f} s)"
            + (f", {lateness.line()}" if lateness is not None else "")
        )
    summary = (
        f"a new sample every {1e3 * period:.1f} ms ({seen:.0f} seen/s), age median {1e3 * figures['age_median_s']:.2f} ms, "
        f"p95 {1e3 * figures['age_p95_s']:.2f} ms"
    )
    return judged("state", figures, limits, failures, summary)


# ----- following a trajectory --------------------------------------------------------------------


def best_lag(
    t_rel: NDArray[np.float64], q: NDArray[np.float64], traj: JointTrajectory, joints: NDArray[np.bool_]
) -> float:
    """The shift tau (s) minimising the mean square of q(t) - q_cmd(t - tau) over `joints`
    (module docstring); NaN with fewer than 5 samples."""
    if t_rel.size < 5 or not joints.any():
        return float("nan")
    step = 0.0005
    shifts = np.arange(-bounds.LAG_SEARCH_S, bounds.LAG_SEARCH_S + 1e-12, step)
    cost = np.empty(shifts.size)
    for i, tau in enumerate(shifts):
        qc, _, _ = traj.sample(t_rel - tau)
        cost[i] = float(np.mean((q[:, joints] - qc[:, joints]) ** 2))
    k = int(np.argmin(cost))
    if 0 < k < shifts.size - 1:
        c0, c1, c2 = cost[k - 1], cost[k], cost[k + 1]
        curvature = c0 - 2 * c1 + c2
        if curvature > 0:
            return float(shifts[k] + 0.5 * step * (c0 - c2) / curvature)
    return float(shifts[k])


def following_figures(
    samples: Samples, traj: JointTrajectory, t0: float, window: tuple[float, float] | None = None
) -> dict[str, Any]:
    """RMS and largest error (worst joint, rad) of the new states during `traj` commanded at t0,
    and the lag (s) over `window` (on the trajectory's axis; default: all of it)."""
    new = samples.new()
    t_rel = new.t - t0
    during = (t_rel >= 0) & (t_rel <= traj.duration)
    if during.sum() < 5:
        return {"states": int(during.sum()), "rms_rad": float("nan"), "max_rad": float("nan"), "lag_s": float("nan")}
    qc, _, _ = traj.sample(t_rel[during])
    err = new.q[during] - qc
    rms = np.sqrt(np.mean(err**2, axis=0))  # per joint
    a, b = window if window is not None else (0.0, traj.duration)
    inside = during & (t_rel >= a) & (t_rel <= b)
    # the joints that move in the window (more than 1 mrad): the others carry no timing
    commanded, _, _ = traj.sample(np.linspace(max(a, 0.0), min(b, traj.duration), 200))
    moving = np.ptp(commanded, axis=0) > 1e-3
    return {
        "states": int(during.sum()),
        "rms_rad": float(np.max(rms)),
        "max_rad": float(np.max(np.abs(err))),
        "worst_joint": int(np.argmax(rms)),
        "lag_s": best_lag(t_rel[inside], new.q[inside], traj, moving),
    }


def probe_following(
    name: str,
    arm: Arm,
    model: ArmModel,
    clock: Clock,
    traj: JointTrajectory,
    *,
    rms_max: float,
    max_max: float,
    window: tuple[float, float] | None = None,
    extra: dict[str, float] | None = None,
    keep: list[Recording] | None = None,
) -> CheckResult:
    """Command `traj`, record it and the settling after it, and judge how it was followed (the
    recording goes to `keep`)."""
    mark = host_mark(clock)
    t0, call_s = timed_command(arm, clock, traj)
    samples = record(arm, clock, traj.duration + bounds.SETTLE_S)
    lateness = host_lateness(clock, mark)
    if keep is not None:
        keep.append(Recording(samples, traj, t0))
    figures: dict[str, Any] = {**following_figures(samples, traj, t0, window), **(extra or {})}
    figures["command_call_s"] = call_s
    peak = float(np.max(np.abs(traj.velocities) / model.velocity_limit))
    figures["duration_s"] = traj.duration
    figures["peak_speed_of_limit"] = peak
    worst = figures.get("worst_joint")
    if isinstance(worst, int):
        figures["worst_joint"] = model.joint_names[worst]
    limits = {"rms_rad": {"max": rms_max}, "max_rad": {"max": max_max}, "lag_s": {"abs_max": bounds.LAG_MAX_S}}
    rms, largest, lag = (float(figures[k]) for k in ("rms_rad", "max_rad", "lag_s"))
    failures = []
    if not np.isfinite(rms):
        failures.append(f"only {figures['states']} new states while the trajectory ran: nothing to judge it by")
    else:
        if rms > rms_max:
            failures.append(f"RMS error {1e3 * rms:.1f} mrad ({worst_name(figures)}) > {1e3 * rms_max:.1f} mrad")
        if largest > max_max:
            failures.append(f"largest error {1e3 * largest:.1f} mrad > {1e3 * max_max:.1f} mrad")
        where = "at the release" if window is not None else "over the motion"
        if not np.isfinite(lag):
            failures.append(f"the lag {where} could not be measured (too few states)")
        elif abs(lag) > bounds.LAG_MAX_S:
            failures.append(
                f"lags its command by {1e3 * lag:.1f} ms {where} (|lag| > {1e3 * bounds.LAG_MAX_S:.0f} ms)"
                if lag > 0
                else f"leads its command by {-1e3 * lag:.1f} ms {where} (|lag| > {1e3 * bounds.LAG_MAX_S:.0f} ms)"
            )
    # the states are judged at their own timestamps, whenever the host read them; what the host
    # distorts is the motion's start: a call of command_trajectory it stalled starts it late
    if failures and call_s >= bounds.LAG_MAX_S:
        figures["host_late"] = f"command_trajectory returned {1e3 * call_s:.1f} ms after it was called"
    elif failures and not np.isfinite(rms) and lateness is not None and lateness.late:
        figures["host_late"] = lateness.line()
    summary = (
        f"RMS {1e3 * rms:.2f} mrad, largest {1e3 * largest:.2f} mrad, lag {1e3 * lag:.1f} ms "
        f"({figures['states']} states at up to {100 * peak:.0f} % of the velocity limits)"
    )
    return judged(name, figures, limits, failures, summary)


def worst_name(figures: dict[str, Any]) -> str:
    return f"joint {figures.get('worst_joint', '?')}"


def probe_scaled_throw(
    arm: Arm, model: ArmModel, clock: Clock, ball: Ball | None = None, keep: list[Recording] | None = None
) -> CheckResult:
    """The throw planned from the arm's model, slowed down (`motions.scaled_throw`), from the arm's
    pose: followed, the lag measured around the release. Not run when the model plans no throw."""
    try:
        throw = motions.scaled_throw(model, np.array(arm.state().q, dtype=float), ball)
    except ThrowingError as exc:
        return not_run("scaled throw", f"no throw planned from the model of arm {model.name!r}: {exc}")
    w = bounds.RELEASE_WINDOW_S
    return probe_following(
        "scaled throw",
        arm,
        model,
        clock,
        throw.trajectory,
        rms_max=bounds.THROW_RMS_MAX_RAD,
        max_max=bounds.THROW_MAX_MAX_RAD,
        window=(throw.release_time - w, throw.release_time + w),
        extra={
            "release_time_s": throw.release_time,
            "time_scale": throw.scale,
            "target_x_m": throw.target[0],
            "target_z_m": throw.target[1],
        },
        keep=keep,
    )


# ----- limits ------------------------------------------------------------------------------------


def probe_limits(arm: Arm, model: ArmModel, clock: Clock) -> CheckResult:
    """Commands beyond each joint's limits refused, nothing moved (module docstring)."""
    q0 = np.array(arm.state().q, dtype=float)
    accepted: list[str] = []
    wrong: list[str] = []
    start = clock.now()
    for j, joint in enumerate(model.joint_names):
        for side, value in (
            ("upper", model.upper[j] + bounds.BEYOND_LIMIT_RAD),
            ("lower", model.lower[j] - bounds.BEYOND_LIMIT_RAD),
        ):
            q = q0.copy()
            q[j] = value
            try:
                arm.command_position(q)
            except LimitError:
                continue
            except Exception as exc:  # refused, but not as the contract says
                arm.stop()
                wrong.append(f"{joint} {side}: {type(exc).__name__}: {exc}")
                continue
            arm.stop()  # it took the command: brake at once
            accepted.append(f"{joint} {side}")
    samples = record(arm, clock, 0.1)
    moved = float(np.max(np.abs(samples.q - q0)))
    beyond = np.full((2, model.nq), q0)
    beyond[:, 0] = model.upper[0] + bounds.BEYOND_LIMIT_RAD
    host_refuses = not validate(
        JointTrajectory(np.array([0.0, 0.001]), beyond, np.zeros_like(beyond), np.zeros_like(beyond)), model
    ).ok
    figures = {
        "commands": 2 * model.nq,
        "refused_with_limit_error": 2 * model.nq - len(accepted) - len(wrong),
        "accepted": accepted,
        "refused_otherwise": wrong,
        "moved_rad": moved,
        "probe_s": float(clock.now() - start),
        "host_validator_refuses_trajectory_beyond_limit": host_refuses,
    }
    limits = {"moved_rad": {"max": bounds.REFUSED_MOTION_MAX_RAD}}
    failures = []
    if accepted:
        failures.append(f"took {len(accepted)} command(s) beyond a joint limit ({', '.join(accepted[:3])})")
    if wrong:
        failures.append(f"refused {len(wrong)} with another error than LimitError ({wrong[0]})")
    if moved > bounds.REFUSED_MOTION_MAX_RAD:
        failures.append(
            f"moved {1e3 * moved:.1f} mrad on refused commands (> {1e3 * bounds.REFUSED_MOTION_MAX_RAD:.0f} mrad)"
        )
    if not host_refuses:
        failures.append("the host's validator let a trajectory beyond a joint limit through")
    summary = (
        f"{2 * model.nq} position commands {1e3 * bounds.BEYOND_LIMIT_RAD:.0f} mrad beyond a limit refused by the "
        f"driver (LimitError), moved {1e3 * moved:.2f} mrad; trajectories: refused by the host's validator"
    )
    return judged("limits refused", figures, limits, failures, summary)


# ----- Stop --------------------------------------------------------------------------------------


def probe_stop(arm: Arm, model: ArmModel, clock: Clock, traj: JointTrajectory) -> CheckResult:
    """Stop during `traj` (module docstring)."""
    t0 = command(arm, clock, traj)
    at = bounds.STOP_AT_FRACTION * traj.duration
    before = record(arm, clock, max(0.0, t0 + at - clock.now()))
    t_stop = clock.now()
    qc, dqc, ddqc = traj.sample(min(t_stop - t0, traj.duration))
    brake = plan_stop(qc, dqc, ddqc, model)
    q_brake_end = brake.end[0]
    arm.stop()
    stop_call_s = clock.now() - t_stop  # the brake is planned from the command at t_stop
    window = brake.duration + bounds.STOP_SETTLE_MAX_S + 0.3
    after = record(arm, clock, window).new().after(t_stop)
    q_all = np.vstack([before.q, after.q]) if after.t.size else before.q
    margin = np.minimum(q_all - model.lower, model.upper - q_all)
    moving = np.max(np.abs(after.dq), axis=1) >= bounds.REST_SPEED_RAD_S if after.t.size else np.array([True])
    unseen = 0.0
    if after.t.size == 0 or moving[-1]:
        to_rest = float("nan")
    else:
        last_moving = np.flatnonzero(moving)
        first_rest = int(last_moving[-1]) + 1 if last_moving.size else 0
        to_rest = float(after.t[first_rest] - t_stop)
        # the arm came to rest somewhere between the last state moving and the first at rest
        unseen = float(after.t[first_rest] - after.t[first_rest - 1]) if first_rest > 0 else 0.0
    q_final = after.q[-1] if after.t.size else before.q[-1]
    overshoot = float(np.max(np.abs(q_final - q_brake_end)))
    rest_bound = brake.duration + bounds.STOP_SETTLE_MAX_S
    figures: dict[str, Any] = {
        "speed_at_stop_of_limit": float(np.max(np.abs(dqc) / model.velocity_limit)),
        "ideal_brake_s": float(brake.duration),
        "to_rest_s": to_rest,
        "beyond_ideal_brake_end_rad": overshoot,
        "travel_after_stop_rad": float(np.max(np.abs(q_final - qc))),
        "ideal_travel_rad": float(np.max(np.abs(q_brake_end - qc))),
        "closest_to_limit_rad": float(np.min(margin)),
    }
    limits = {
        "to_rest_s": {"max": rest_bound},
        "beyond_ideal_brake_end_rad": {"max": bounds.STOP_OVERSHOOT_MAX_RAD},
        "closest_to_limit_rad": {"min": 0.0},
    }
    failures = []
    if not np.isfinite(to_rest):
        failures.append(
            f"ignored Stop: still moving {window:.2f} s after it (the limits brake in {brake.duration:.2f} s)"
        )
    elif to_rest > rest_bound:
        failures.append(
            f"at rest {to_rest:.2f} s after Stop > {rest_bound:.2f} s (brake {brake.duration:.2f} s + settling)"
        )
    if overshoot > bounds.STOP_OVERSHOOT_MAX_RAD:
        where = "came to rest" if np.isfinite(to_rest) else f"was, {window:.2f} s after Stop,"
        failures.append(
            f"{where} {1e3 * overshoot:.0f} mrad past where the brake ends "
            f"(> {1e3 * bounds.STOP_OVERSHOOT_MAX_RAD:.0f} mrad)"
        )
    if figures["closest_to_limit_rad"] < 0:
        failures.append(f"a joint went {-1e3 * figures['closest_to_limit_rad']:.1f} mrad beyond its limit")
    figures["stop_call_s"] = stop_call_s
    # Stop is judged from the command at t_stop: a host that stalled the thread before stop() took
    # effect let the arm run on (its rest and its overshoot come late), not an arm that ignores Stop;
    # a host that read no state for long when the arm came to rest cannot say when it did
    figures["rest_unseen_s"] = unseen
    if failures and np.isfinite(to_rest) and figures["closest_to_limit_rad"] >= 0:
        if stop_call_s >= HOST_LATE_S:
            figures["host_late"] = f"stop() took effect {1e3 * stop_call_s:.1f} ms after the brake was planned"
        elif overshoot <= bounds.STOP_OVERSHOOT_MAX_RAD and to_rest - unseen <= rest_bound:
            figures["host_late"] = f"it read no state for {1e3 * unseen:.0f} ms when the arm came to rest"
    summary = (
        f"at rest {to_rest:.3f} s after Stop (the limits brake in {brake.duration:.3f} s), "
        f"{1e3 * overshoot:.1f} mrad from the brake's end, within the limits"
    )
    return judged("stop", figures, limits, failures, summary)
