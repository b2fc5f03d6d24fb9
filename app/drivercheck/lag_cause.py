"""Which term a lagging arm's controller is missing, measured: `diagnose`, whose line the check
that found the arm off its command (slow motion, scaled throw) adds to its reason.

Real controllers that take position setpoints differ in what they add to a joint PD: a lab's
community model may add nothing. Two measurements tell the missing terms apart:

1. **Gravity, at rest under several loads.** The arm rests at A (where the failed motion left it)
   and at up to `REST_POSES` more poses B (each A with one joint turned by up to
   `GRAVITY_STEP_RAD` within the limits, reached slowly: the turn that changes the gravity torque
   by `GRAVITY_CHANGE_MIN_NM` or more on the most joints that carry one and no pose before changed
   enough); at each, after `REST_SETTLE_S`, the mean offset e = q - q_cmd over `REST_MEASURE_S`,
   and the gravity torque g(q) from the arm's model (Pinocchio, its URDF's inertials). A
   controller without gravity compensation sags by what its stiffness K leaves of the torque it
   holds, e = -g / K: a joint sags when, between A and the pose that changed its torque most (by
   `GRAVITY_CHANGE_MIN_NM` or more), its compliance c = (e_B - e_A) / (g_B - g_A) is negative, its
   offsets are within `SAG_FIT` of c g at both, and the larger is `SAG_MIN_RAD` or more: "joint E1
   sags 12.0 mrad at rest where gravity pulls 40 N m: the controller has no gravity compensation".
2. **Speed, on the motion that failed.** The moving joints' positions against two models of a
   lag, each fitted (one time constant for all of them, every joint's constant offset aside) by
   its least RMS residual: a *delay*, q(t) = q_cmd(t - tau), the commands reaching the servo late
   (a queue), which no feed-forward removes; and a *first-order lag*, tau q' + q = q_cmd, what a
   joint PD whose damping acts on the measured speed (no velocity feed-forward) gives at D / K =
   tau. The model whose residual is at most `MODEL_RATIO` of the other's names the term; where
   neither is that much better, both are named. A lag beyond the lag bound (`bounds.LAG_MAX_S`)
   only.

The remedy for both missing terms is the arm's inverse dynamics fed forward (gravity, and the
velocity and inertia terms), `wiithrow.robot.feedforward`; a delay is the driver's to remove.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np
import pinocchio as pin
import scipy.signal
from numpy.typing import NDArray

from wiithrow.app.drivercheck import bounds, motions
from wiithrow.app.drivercheck.probes import Recording, record
from wiithrow.app.errors import AppError, expected_errors
from wiithrow.clock import Clock
from wiithrow.robot import Arm, ArmModel

#: A rest pose B turns one joint by up to this much (rad; a gravity torque near its largest, as the
#: Panda's elbow at its home, changes by 1 - cos(0.5) = 12 % of it), within the limits.
GRAVITY_STEP_RAD = 0.5
#: At most this many poses B.
REST_POSES = 2
#: A joint is judged for sag only when a pose B changed its gravity torque by this (N m): a
#: compliance fitted to a smaller change is noise.
GRAVITY_CHANGE_MIN_NM = 2.0
#: A joint sags when its offset at the heavier pose is at least this (rad): 1 mm at the ball.
SAG_MIN_RAD = 0.001
#: Its offsets at both poses within this fraction (of the larger) of the compliance's line c g.
SAG_FIT = 0.3
#: The arm rests when no joint moved faster than `bounds.REST_SPEED_RAD_S` for this long (s);
#: it has this long (s) to.
STILL_S = 0.1
STILL_TIMEOUT_S = 10.0
#: At each rest pose the arm settles this long (s), then its offset is averaged over this (s).
REST_SETTLE_S = 1.0
REST_MEASURE_S = 0.2
#: One part of the lag model names the term when it is at least this fraction of the whole lag
#: (the MuJoCo world's arm 50 ms late through a queue: its delay 100 %; a PD with D / K = 90 ms:
#: its first-order lag 100 %).
PART_MIN = 0.75
#: The delays and time constants the lag model is fitted over (s).
LAG_GRID_S = np.arange(0.0, 0.2001, 0.004)
#: The remedy the report names.
FEEDFORWARD = "feed the inverse dynamics forward (wiithrow.robot.feedforward)"


@dataclass
class Diagnosis:
    """What was found: one `line` per missing term (empty: none found) and the `figures`."""

    lines: list[str] = field(default_factory=list)
    figures: dict[str, Any] = field(default_factory=dict)

    def reason(self) -> str:
        """The lines as the clause a failed check's reason ends with, and the remedy."""
        if not self.lines:
            return ""
        missing = any("controller has no" in x or "controller without" in x for x in self.lines)
        fix = f"; {FEEDFORWARD}" if missing else ""
        return "; ".join(self.lines) + fix


def gravity_torques(model: ArmModel, q: NDArray[np.float64]) -> NDArray[np.float64]:
    """The torque (N m) gravity puts on each joint at q (the model's inertials)."""
    return np.array(pin.computeGeneralizedGravity(model.model, model.model.createData(), np.asarray(q, dtype=float)))


def lag_model(recording: Recording) -> dict[str, float]:
    """The lag model fitted to the motion that failed (module docstring): its delay and its
    first-order time constant (s) and the RMS residual (rad); empty with fewer than 20 states."""
    traj = recording.traj
    assert traj is not None
    new = recording.samples.new()
    t_rel = new.t - recording.t0
    inside = (t_rel >= 0.0) & (t_rel <= traj.duration + bounds.SETTLE_S)
    t, q = t_rel[inside], new.q[inside]
    grid = np.arange(-0.5, traj.duration + bounds.SETTLE_S + 0.001, 0.001)
    commanded = traj.sample(np.clip(grid, 0.0, traj.duration))[0]
    joints = np.flatnonzero(np.ptp(commanded, axis=0) > 1e-3)
    if t.size < 20 or joints.size == 0:
        return {}
    best = (float("inf"), 0.0, 0.0)
    for lag in LAG_GRID_S:
        a = 1.0 - np.exp(-0.001 / lag) if lag > 0 else 1.0  # lag y' + y = u, exact for u held over 1 ms
        filtered = scipy.signal.lfilter([a], [1.0, a - 1.0], commanded - commanded[0], axis=0) + commanded[0]
        for delay in LAG_GRID_S:
            e = np.column_stack([q[:, j] - np.interp(t - delay, grid, filtered[:, j]) for j in joints])
            rms = float(np.sqrt(np.mean((e - e.mean(axis=0)) ** 2)))  # every joint's offset aside
            best = min(best, (rms, float(delay), float(lag)))
    return {"delay_s": best[1], "lag_s": best[2], "residual_rad": best[0]}


def wait_still(arm: Arm, clock: Clock, timeout_s: float = STILL_TIMEOUT_S) -> bool:
    """Read the arm until no joint has moved faster than `bounds.REST_SPEED_RAD_S` for
    `STILL_S` (an arm that sags is never "idle" by a driver that wants it on its command, yet it
    rests); False after `timeout_s`."""
    start = clock.now()
    since = start
    while clock.now() - start <= timeout_s:
        if np.max(np.abs(arm.state().dq)) >= bounds.REST_SPEED_RAD_S:
            since = clock.now()
        elif clock.now() - since >= STILL_S:
            return True
        clock.sleep(bounds.POLL_S * 10)
    return False


def _rest_offset(arm: Arm, clock: Clock, q_cmd: NDArray[np.float64]) -> NDArray[np.float64]:
    clock.sleep(REST_SETTLE_S)
    samples = record(arm, clock, REST_MEASURE_S).new()
    return np.asarray(np.mean(samples.q, axis=0) - q_cmd)


def rest_poses(model: ArmModel, q_a: NDArray[np.float64]) -> list[NDArray[np.float64]]:
    """The poses B of the module docstring, chosen greedily: each the turn of one joint within the
    limits that changes the gravity torque enough on the most joints no pose before did."""
    g_a = gravity_torques(model, q_a)
    covered = np.abs(g_a) < GRAVITY_CHANGE_MIN_NM  # a joint that carries no torque needs no pose
    poses: list[NDArray[np.float64]] = []
    for _ in range(REST_POSES):
        best, best_key = None, (0, 0.0)
        for j in range(model.nq):
            q_b = q_a.copy()
            q_b[j] = motions.excursion(model, q_a, GRAVITY_STEP_RAD)[j]
            try:
                motions.slow_move(model, q_a, q_b)  # within the limits, above the floor
            except AppError:
                continue
            change = np.abs(gravity_torques(model, q_b) - g_a)
            key = (int(np.sum((change >= GRAVITY_CHANGE_MIN_NM) & ~covered)), float(np.sum(change)))
            if key > best_key:
                best, best_key = q_b, key
        if best is None or best_key[0] == 0:
            break
        poses.append(best)
        covered |= np.abs(gravity_torques(model, best) - g_a) >= GRAVITY_CHANGE_MIN_NM
    return poses


def _move(arm: Arm, model: ArmModel, clock: Clock, q: NDArray[np.float64]) -> None:
    """Slowly to q (validated, from where the arm is), and wait until it rests."""
    arm.command_trajectory(motions.slow_move(model, np.array(arm.state().q, dtype=float), q))
    if not wait_still(arm, clock):
        raise AppError("the arm did not come to rest at a pose of the gravity probe")


def gravity_sag(arm: Arm, model: ArmModel, clock: Clock, q_a: NDArray[np.float64]) -> dict[str, Any]:
    """The offsets at rest at A (the arm's command, held) and at the poses B, and the torques
    there (module docstring); the arm ends back at A. Empty when no pose B is within the limits.
    A move the driver refuses (a driver whose start check compares with its command, which a
    sagging arm is off by more than its tolerance) ends the probe with the poses measured so far,
    and the refusal in `refused`."""
    poses = rest_poses(model, q_a)
    if not poses:
        return {}
    offsets = [_rest_offset(arm, clock, q_a)]
    refused = ""
    try:
        for q_b in poses:
            _move(arm, model, clock, q_b)
            offsets.append(_rest_offset(arm, clock, q_b))
    except expected_errors() as exc:
        arm.stop()
        refused = f"{type(exc).__name__}: {exc}"
    try:
        _move(arm, model, clock, q_a)
    except expected_errors() as exc:
        arm.stop()
        refused = refused or f"{type(exc).__name__}: {exc}"
    measured = [q_a, *poses][: len(offsets)]
    return {
        "poses_rad": [q.tolist() for q in measured],
        "offsets_rad": [e.tolist() for e in offsets],
        "gravity_nm": [gravity_torques(model, q).tolist() for q in measured],
        "refused": refused,
    }


def diagnose(
    arm: Arm, model: ArmModel, clock: Clock, recording: Recording, q_rest: NDArray[np.float64] | None
) -> Diagnosis:
    """Which terms the arm's controller is missing (module docstring), from the motion that failed
    (`recording`) and, when `q_rest` (the pose it was commanded to rest at) is given, the rest
    under several gravity loads. The arm must be at rest; it ends where it was."""
    found = Diagnosis()
    if q_rest is not None:
        sag = gravity_sag(arm, model, clock, np.asarray(q_rest, dtype=float))
        found.figures["rest"] = sag
        found.lines += _sag_lines(model, sag)
    fit = lag_model(recording)
    found.figures["lag_model"] = fit
    found.lines += _lag_lines(fit)
    return found


def _sag_lines(model: ArmModel, sag: dict[str, Any]) -> list[str]:
    """The sag's line (module docstring), none when no joint sags."""
    if not sag or len(sag["offsets_rad"]) < 2:
        return []
    e, g = np.array(sag["offsets_rad"]), np.array(sag["gravity_nm"])
    sagging = []
    for j in range(model.nq):
        k = 1 + int(np.argmax(np.abs(g[1:, j] - g[0, j])))  # the pose that changed its torque most
        if abs(g[k, j] - g[0, j]) < GRAVITY_CHANGE_MIN_NM:
            continue
        c = (e[k, j] - e[0, j]) / (g[k, j] - g[0, j])
        largest = max(abs(e[0, j]), abs(e[k, j]))
        fits = all(abs(e[i, j] - c * g[i, j]) <= SAG_FIT * largest for i in (0, k))
        heavy = 0 if abs(g[0, j]) >= abs(g[k, j]) else k
        if c < 0 and fits and abs(e[heavy, j]) >= SAG_MIN_RAD:
            sagging.append((abs(e[heavy, j]), j, abs(g[heavy, j]), c))
    if not sagging:
        return []
    sagging.sort(reverse=True)
    sag_rad, j, torque, c = sagging[0]
    others = f" (and {', '.join(model.joint_names[k] for _, k, *_ in sagging[1:])})" if len(sagging) > 1 else ""
    return [
        f"joint {model.joint_names[j]} sags {1e3 * sag_rad:.1f} mrad at rest where gravity pulls {torque:.0f} N m"
        f"{others}, {1e3 * abs(c):.2f} mrad per N m: the controller has no gravity compensation"
    ]


def _lag_lines(fit: dict[str, float]) -> list[str]:
    """The lag's line (module docstring), none below the lag bound."""
    if not fit or fit["delay_s"] + fit["lag_s"] <= bounds.LAG_MAX_S:
        return []
    delay, lag = fit["delay_s"], fit["lag_s"]
    how = f"(the model {1e3 * fit['residual_rad']:.2f} mrad RMS from the arm)"
    if lag >= PART_MIN * (delay + lag):
        return [
            f"it lags in proportion to its speed, a first-order lag of {1e3 * lag:.0f} ms {how}: the controller has "
            "no velocity feed-forward (its damping acts on the measured speed)"
        ]
    if delay >= PART_MIN * (delay + lag):
        return [
            f"it follows its command {1e3 * delay:.0f} ms late, a delay {how}: the commands reach the servo late "
            "(a queue), which no feed-forward removes"
        ]
    return [
        f"it follows its command {1e3 * delay:.0f} ms late and lags {1e3 * lag:.0f} ms more in proportion to its "
        f"speed {how}: the commands reach the servo late (a queue), and the controller has no velocity feed-forward"
    ]
