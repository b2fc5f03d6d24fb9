"""`SimulatedArm`: an `Arm` that integrates an ideal position servo at a fixed rate on an injected clock.

Time: the simulation advances lazily, in steps of dt = 1/rate_hz, up to `clock.now()` whenever the
state is read or a command is given; with a simulated clock nothing happens until the clock moves,
with a real clock it keeps up with real time. A command starts at the last simulated step.

The servo, one step k -> k+1 for each joint, with (q, v) the state and (q_ref, v_ref) the active
command's reference at t_{k+1} (or the hold position and 0 when idle):

    exact:   v_exact = (q_ref - q) / dt,  a_exact = (v_exact - v) / dt
             used if |v_exact| <= v_max and |a_exact| <= a_max (a feasible reference is followed
             exactly: v <- v_exact, q <- q_ref)
    else:    v_des = v_ref + sign(e) min(|e|/dt, sqrt(a_max |e|)),  e = q_ref - q
             (approach the reference braking at half the acceleration limit, so it does not overshoot)
             a = clip((v_des - v)/dt, +-a_max),  v <- clip(v + a dt, +-v_max)
    then     q <- q + v dt

so velocity and acceleration limits hold at every step; a step in which a joint had to be limited
counts in `saturated_steps` (the observable sign that a command was not followed exactly). A joint
that would leave its position limits is stopped hard at the limit (counted in
`position_clamped_steps`; the only case that may exceed the acceleration limit, and one that
validated commands never reach). Jerk is limited by the commands (Ruckig plans), not by the servo.

Commands: `command_position` plans a Ruckig move from the current state (the running command's own
state when the servo is on it, for a seamless change); `stop` plans Ruckig's velocity-interface
brake; a command that ends in motion (a throw's release) continues into such a brake from its end
state at its end time; once a command ends at rest the servo holds its last position.

Tracking error: the reported (and "actual") position is the servo's plus e, a per-joint Gaussian
AR(1) process with standard deviation `tracking_error_rad` and correlation time
`tracking_error_tau` (s):  e <- rho e + sqrt(1 - rho^2) sigma w,  rho = exp(-dt/tau),  w ~ N(0, 1).
`ideal_state()` gives the servo's state without it. Velocities carry no tracking error. A
trajectory commanded from a slightly different position (within `start_tolerance_rad`) starts the
servo on it, and the gap joins e (so the reported position does not jump, and then decays).

Many steps at once: every read steps up to now with the stretches of exact following computed
vectorised (`_follow`: the very numbers `_step` gives, one step at a time; a reader at 100 Hz
finds ten steps to take); `ideal_path` gives the ideal state at many times the same way (a
host that needs every servo period's reference, `MujocoArm`); `snapshot`/`restore` take steps back.

Thread-safety: every public method holds one lock (a UI thread may call `stop()` while a control
loop reads `state()`); `wait_until_idle` sleeps without holding it.
"""

from __future__ import annotations

import math
import threading

import numpy as np
from numpy.typing import ArrayLike, NDArray

from wiithrow.robot.errors import RobotError, StartMismatchError
from wiithrow.robot.following import FollowTable, exact_rows, follow_table
from wiithrow.robot.interface import Clock, JointState
from wiithrow.robot.limits import JointLimits
from wiithrow.robot.model import ArmModel
from wiithrow.robot.position_history import PositionHistory
from wiithrow.robot.simulated_snapshot import SimulatedArmSnapshot, restore_snapshot, take_snapshot
from wiithrow.robot.trajectory import JointTrajectory, check_trajectory, plan_move, plan_stop

_EPS_V = 1e-12  # rad/s: below this a joint is at rest


class SimulatedArm:
    """A simulated position-controlled arm implementing `wiithrow.robot.interface.Arm`.

    `arm_model`: the kinematic model (its limits are enforced); `clock`: an object with now() and
    sleep(); `rng`: numpy Generator for the tracking error (default: seeded with 0);
    `tracking_error_rad`: std of the joint tracking error (rad, default 0); `rate_hz`: servo rate;
    `q0`: start configuration at rest (default `arm_model.home`); `limits`: override the model's
    limits (e.g. `arm_model.limits.scaled(...)`); `history_steps`: steps kept for `position_at`.
    """

    def __init__(
        self,
        arm_model: ArmModel,
        clock: Clock,
        *,
        rng: np.random.Generator | None = None,
        tracking_error_rad: float = 0.0,
        tracking_error_tau: float = 0.02,
        rate_hz: float = 1000.0,
        q0: ArrayLike | None = None,
        limits: JointLimits | None = None,
        start_tolerance_rad: float = 0.01,
        history_steps: int = 0,
    ) -> None:
        if not (np.isfinite(rate_hz) and rate_hz > 0):
            raise RobotError(f"rate_hz must be > 0, got {rate_hz}")
        if not (np.isfinite(tracking_error_rad) and tracking_error_rad >= 0):
            raise RobotError(f"tracking_error_rad must be >= 0, got {tracking_error_rad}")
        if not (np.isfinite(tracking_error_tau) and tracking_error_tau >= 0):
            raise RobotError(f"tracking_error_tau must be >= 0, got {tracking_error_tau}")
        self.arm_model = arm_model
        self.limits = arm_model.limits if limits is None else limits
        if self.limits.n != arm_model.nq:
            raise RobotError(f"limits are for {self.limits.n} joints, the arm has {arm_model.nq}")
        self.clock = clock
        self.dt = 1.0 / float(rate_hz)
        self.tracking_error_rad = float(tracking_error_rad)
        self.tracking_error_tau = float(tracking_error_tau)
        self.start_tolerance_rad = float(start_tolerance_rad)
        self._rng = np.random.default_rng(0) if rng is None else rng
        self._rho = math.exp(-self.dt / self.tracking_error_tau) if self.tracking_error_tau > 0 else 0.0
        n = arm_model.nq
        self._lock = threading.RLock()
        self._t0 = float(clock.now())
        self._k = 0  # steps simulated since _t0 (integer, so time does not drift)
        self._q = self.limits.check_position(arm_model.home if q0 is None else q0, "q0")
        self._v = np.zeros(n)
        self._a = np.zeros(n)
        self._hold = self._q.copy()
        self._err = self._rng.normal(0.0, self.tracking_error_rad, n) if self.tracking_error_rad > 0 else np.zeros(n)
        self._cmd: JointTrajectory | None = None
        self._cmd_k = 0  # steps of the command done
        self._cmd_offset = 0.0  # s: the command's start precedes the step it was given at by this
        self._cmd_moving_end = False  # the command ends in motion: continue into a brake
        self._cmd_kind = ""
        self.saturated_steps = 0
        self.position_clamped_steps = 0
        self.commands_started = 0  # moves, trajectories, stops and the brakes ends in motion go on into
        self._table: FollowTable | None = None  # the command's exact following (`_follow_table`)
        # (table, k, q, v): the state q, v (these very arrays) is the table's at the command's step k
        self._table_mark: tuple[FollowTable | None, int, object, object] = (None, 0, None, None)
        self._history = PositionHistory(history_steps, n) if history_steps > 0 else None  # `position_at`
        self._remember(1)

    # ----- Arm protocol -------------------------------------------------------------------------

    def state(self) -> JointState:
        """The reported joint state (with tracking error) at the last simulated step <= clock.now()."""
        return self._state_now()

    def _state_now(self) -> JointState:
        """`state()`'s reading for the world's own cameras (never a wrapped or replaced `state`)."""
        with self._lock:
            self._advance()
            return JointState(self._t, self._q + self._err, self._v.copy())

    def position_at(self, t: float) -> NDArray[np.float64]:
        """The reported position at the last step at or before `t` (<= now): what a camera whose frame
        of time t made late saw, from the last `history_steps` steps; older, or without, the position now."""
        return (self.state_at(t) or self._state_now()).q

    def state_at(self, t: float) -> JointState | None:
        """The reported state at the last step at or before `t` (<= now; velocities carry no tracking
        error) from the last `history_steps` steps (`PositionHistory`); None when older, or without one."""
        with self._lock:
            self._advance()
            k = self._k + math.floor((t - self._t) / self.dt + 1e-9)
            if k >= self._k:
                return JointState(self._t, self._q + self._err, self._v.copy())
            kept = self._history.state(k) if self._history is not None else None
            return None if kept is None else JointState(self._t0 + k * self.dt, *kept)

    def command_position(self, q: ArrayLike) -> None:
        """Move to `q` along a time-optimal jerk-limited Ruckig trajectory from the current state.

        Raises LimitError naming the joint if `q` is outside the position limits.
        """
        goal = self.limits.check_position(q, "command_position target")
        with self._lock:
            self._advance()
            q0, v0, a0 = self._start_state()
            self._start(plan_move(q0, goal, self.limits, self.dt, v_start=v0, a_start=a0), "move")

    def command_trajectory(self, traj: JointTrajectory) -> None:
        """Follow `traj` from now on (its `times[0]` is mapped to the current step).

        Raises LimitError if it leaves the limits, StartMismatchError if its first position is more than
        `start_tolerance_rad` from the arm's (plan it from `state()`). A smaller gap (e.g. the
        tracking error in the state it was planned from) joins the tracking error: the reported
        position stays continuous and converges to the trajectory with `tracking_error_tau`.
        """
        if not isinstance(traj, JointTrajectory):
            raise RobotError(f"command_trajectory needs a JointTrajectory, got {type(traj).__name__}")
        check_trajectory(traj, self.limits)
        with self._lock:
            self._advance()
            gap = np.abs(traj.positions[0] - self._q)
            if np.any(gap > self.start_tolerance_rad):
                j = int(np.argmax(gap))
                raise StartMismatchError(
                    f"the trajectory starts {gap[j]:.4f} rad away from the arm at joint "
                    f"{self.limits.names[j]}; plan it from the arm's current state",
                    self.limits.names[j],
                    float(gap[j]),
                )
            # the servo starts on the trajectory; the actual (reported) position stays where it is,
            # the small gap joins the tracking error and decays with it
            self._err = self._err - (traj.positions[0] - self._q)
            self._q = traj.positions[0].copy()
            self._start(traj, "trajectory")

    def stop(self) -> None:
        """Brake to rest now, as fast as the velocity, acceleration and jerk limits allow."""
        with self._lock:
            self._advance()
            if self._cmd is None and not np.any(np.abs(self._v) > _EPS_V):
                return
            self._brake()

    def is_moving(self) -> bool:
        """True while a command runs or a joint moves."""
        with self._lock:
            self._advance()
            return self._busy()

    def wait_until_idle(self, timeout: float) -> bool:
        """Sleep on the clock (in steps of at most 10 ms) until idle; False if `timeout` s passed first."""
        deadline = self.clock.now() + max(0.0, float(timeout))
        while True:
            if not self.is_moving():
                return True
            remaining = deadline - self.clock.now()
            if remaining <= 0:
                return False
            self.clock.sleep(min(remaining, 0.01))

    # ----- extras for tests and the simulated world ---------------------------------------------

    def ideal_state(self) -> JointState:
        """The servo's state without tracking error."""
        with self._lock:
            self._advance()
            return JointState(self._t, self._q.copy(), self._v.copy())

    def ideal_qv(self) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """(q, dq) of `ideal_state` without copies (the arrays are replaced, never written, as the
        servo steps): for a controller that reads them every millisecond and does not keep them."""
        with self._lock:
            self._advance()
            return self._q, self._v

    def ideal_path(self, times: ArrayLike) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """(q, dq) of `ideal_qv` at each of `times` (s, increasing), as if the clock were moved to
        each in turn and read: rows (len(times), nq), new arrays. For a host that owns this arm's
        clock and moves it along afterwards (`wiithrow.app.worlds.mujoco.devices.MujocoArm`, a
        servo period at a time): the simulation steps up to the last of `times` whatever the
        clock says (until the clock passes that, reading the state steps nothing).

        The same steps as `_advance` would take: exact-following stretches vectorised
        (`_follow`), every other step one at a time (`_step`), a rest jumped over. Equal to the
        per-step path to the bit for q and dq (the same operations on the same numbers);
        without noise the tracking error decays in one go over a stretch: rho^m, not m times rho)."""
        with self._lock:
            t0, dt, k = self._t0, self.dt, self._k
            targets = []
            for t in np.asarray(times, dtype=float).reshape(-1).tolist():
                n = math.floor((t - (t0 + k * dt)) / dt + 1e-9)
                if n > 0:
                    k += n
                targets.append(k)
            total = k - self._k
            Q = np.empty((total + 1, self._q.size))
            V = np.empty_like(Q)
            Q[0], V[0] = self._q, self._v
            self._steps_recorded(Q, V)
            if total == len(targets) and targets[0] == self._k - total + 1:  # a step per time
                return Q[1:], V[1:]
            rows = np.asarray(targets, dtype=np.int64) - (self._k - total)
            return Q[rows], V[rows]

    def snapshot(self) -> SimulatedArmSnapshot:
        """The simulation's whole state, for `restore` (`simulated_snapshot.take_snapshot`)."""
        return take_snapshot(self, self._lock, self._rng if self.tracking_error_rad > 0 else None)

    def restore(self, snapshot: SimulatedArmSnapshot) -> None:
        """Put back a state `snapshot` took (`simulated_snapshot.restore_snapshot`)."""
        restore_snapshot(self, snapshot, self._lock, self._rng)

    @property
    def acceleration(self) -> NDArray[np.float64]:
        """The joint acceleration of the last simulated step (rad/s^2)."""
        with self._lock:
            return self._a.copy()

    @property
    def command_kind(self) -> str:
        """'' when idle, else 'move', 'trajectory' or 'stop' (without advancing time)."""
        with self._lock:
            return self._cmd_kind

    # ----- simulation ---------------------------------------------------------------------------

    @property
    def _t(self) -> float:
        return self._t0 + self._k * self.dt

    def _busy(self) -> bool:
        return (
            self._cmd is not None
            or bool(np.count_nonzero(np.abs(self._v) > _EPS_V))
            or bool(np.count_nonzero(np.abs(self._q - self._hold) > 1e-12))
        )

    def _start(self, traj: JointTrajectory, kind: str, offset: float = 0.0) -> None:
        """Make `traj` the command; its times[0] is `offset` s before the current step."""
        self._cmd, self._cmd_k, self._cmd_kind, self._cmd_offset = traj, 0, kind, offset
        self.commands_started += 1
        self._cmd_moving_end = bool(np.any(np.abs(traj.end[1]) > 1e-9))

    def _start_state(self) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
        """(q, v, a) to plan a new command from: the active command's own state at this step when
        the servo is on it (the servo's velocity is a mean over the last step, half a step late),
        else the servo's state; clipped into the limits."""
        q, v, a = self._q, self._v, self._a
        traj = self._cmd
        if traj is not None:
            rel = self._cmd_offset + self._cmd_k * self.dt
            if rel <= traj.duration:
                q_ref, v_ref, a_ref = traj.sample(traj.times[0] + rel)
                if np.all(np.abs(q_ref - q) < 1e-9):
                    v, a = v_ref, a_ref
        lim = self.limits
        return q.copy(), np.clip(v, -lim.velocity, lim.velocity), np.clip(a, -lim.acceleration, lim.acceleration)

    def _brake(self) -> None:
        q0, v0, a0 = self._start_state()
        self._start(plan_stop(q0, v0, a0, self.limits, self.dt), "stop")

    def _advance(self) -> None:
        """Simulate every step up to the clock's now: `_steps_recorded` into scratch rows (a
        reader at 100 Hz of an arm stepping at 1 kHz finds ten steps to take, most of them exact
        following, which `_follow` takes at once)."""
        n = math.floor((self.clock.now() - self._t) / self.dt + 1e-9)
        if n <= 0:
            return
        Q = np.empty((n + 1, self._q.size))
        V = np.empty_like(Q)
        Q[0], V[0] = self._q, self._v
        self._steps_recorded(Q, V)

    def _steps_recorded(self, Q: NDArray[np.float64], V: NDArray[np.float64]) -> None:
        """Take len(Q) - 1 steps, putting (q, v) after step i into row i: exact-following stretches
        at once (`_follow`), every other step one at a time (`_step`), a rest jumped over."""
        total, i = Q.shape[0] - 1, 0
        while i < total:
            if not self._busy():  # idle: jump, as `_advance`
                self._k += total - i
                self._a = np.zeros_like(self._a)
                self._evolve_error(total - i)
                self._remember(total - i)
                Q[i + 1 :], V[i + 1 :] = self._q, self._v
                return
            m = self._follow(Q, V, i + 1, total - i)
            if m == 0:
                self._step()
                Q[i + 1], V[i + 1] = self._q, self._v
                m = 1
            i += m

    def _follow(self, Q: NDArray[np.float64], V: NDArray[np.float64], row: int, m: int) -> int:
        """Up to `m` steps of the command in which the servo follows it exactly (`_step`'s first
        case, within the position limits), vectorised; their (q, v) into rows `row`... of Q, V.
        Returns how many (0: the next step is not one; `_step` takes it). Stops before a
        command that ends in motion turns into its brake, and after the step that ends one.

        Per step s of the command (r_s its reference, `_follow_table`; q, v the servo's state
        before it):  q <- r_s,  v_s = (r_s - q) / dt,  a_s = (v_s - v) / dt.  Once the servo is on
        the table (q = r_k, v = v_k after an exact step k: after two exact steps in a row, or
        one from the table; `_table_mark` says so while these very arrays are the state), every
        later exact step is the table's, and a stretch is a slice of it."""
        traj = self._cmd
        if traj is None:
            return 0
        table = self._follow_table(traj)
        k0 = self._cmd_k
        last = min(k0 + m, table.steps)  # the last step this stretch may take
        if last <= k0:
            return 0
        mark = self._table_mark
        on_table = mark[0] is table and mark[1] == k0 and mark[2] is self._q and mark[3] is self._v
        if on_table:
            stop = min(last, int(table.next_bad[k0 + 1]) - 1)
            done = stop - k0
            if done <= 0:
                return 0
            q_ref, v, a = table.q[k0 + 1 : stop + 1], table.v[k0 + 1 : stop + 1], table.a[k0 + 1 : stop + 1]
        else:  # from a state off the table (a command's start, after a limited step)
            q_ref = table.q[k0 + 1 : last + 1]
            v = (q_ref - np.vstack([self._q[None, :], q_ref[:-1]])) / self.dt
            a = np.diff(np.vstack([self._v[None, :], v]), axis=0) / self.dt
            ok = exact_rows(q_ref, v, a, self.limits)
            done = q_ref.shape[0] if ok.all() else int(np.argmin(ok))
            if done == 0:
                return 0
        Q[row : row + done], V[row : row + done] = q_ref[:done], v[:done]
        self._q, self._v, self._a = q_ref[done - 1].copy(), v[done - 1].copy(), a[done - 1].copy()
        self._k += done
        self._cmd_k += done
        if done >= 2 or on_table:  # now on the table: q = r_s, v = v_s, the very numbers
            self._table_mark = (table, self._cmd_k, self._q, self._v)
        if self.tracking_error_rad > 0:  # the draws `_step` makes, one per step
            for _ in range(done):
                self._evolve_error(1)
        else:
            self._evolve_error(done)
        self._remember(done, q_ref[:done], v[:done])
        if table.ends and self._cmd_k == table.steps:
            self._finish()
        return done

    def _follow_table(self, traj: JointTrajectory) -> FollowTable:
        """The current command's `FollowTable` (made once per command)."""
        table = self._table
        if table is None or table.traj is not traj or table.offset != self._cmd_offset:
            table = self._table = follow_table(traj, self._cmd_offset, self._cmd_moving_end, self.dt, self.limits)
        return table

    def _remember(self, steps: int, q: NDArray[np.float64] | None = None, v: NDArray[np.float64] | None = None) -> None:
        """The last `steps` steps into the history: rows of `q` (with the tracking error of now) and
        `v`, else all the state now (a jump at rest)."""
        if self._history is not None:
            first = self._k - steps + 1
            if q is None:
                self._history.keep_same(first, steps, self._q + self._err, self._v)
            else:
                self._history.keep_steps(first, q + self._err, v)

    def _evolve_error(self, steps: int) -> None:
        """Advance the AR(1) tracking error by `steps` steps (exactly, in one draw)."""
        # np.count_nonzero: a C call, where ndarray.any() goes through Python (NaN is nonzero for both)
        if self.tracking_error_rad <= 0 and not np.count_nonzero(self._err):
            return
        rho_n = self._rho**steps
        self._err = rho_n * self._err
        if self.tracking_error_rad > 0:
            w = self._rng.normal(0.0, 1.0, self._err.shape)
            self._err += math.sqrt(max(0.0, 1.0 - rho_n * rho_n)) * self.tracking_error_rad * w

    def _reference(self) -> tuple[NDArray[np.float64], NDArray[np.float64], bool]:
        """(q_ref, v_ref) at the next step, and whether that step ends the command.

        A command that ends in motion (e.g. at a release) continues seamlessly into a brake planned
        from its end state at the end's own time, so the reference never jumps.
        """
        traj = self._cmd
        if traj is None:
            return self._hold, np.zeros_like(self._q), False
        k = self._cmd_k + 1
        rel = self._cmd_offset + k * self.dt  # time since the command's start at the next step
        if self._cmd_moving_end and rel > traj.duration + 1e-9:
            q_end, v_end, a_end = traj.end
            brake = plan_stop(
                q_end, v_end, np.clip(a_end, -self.limits.acceleration, self.limits.acceleration), self.limits, self.dt
            )
            self._start(brake, "stop", offset=rel - traj.duration - self.dt)
            return self._reference()
        i = k if self._cmd_offset == 0.0 else -1
        if 0 <= i < traj.times.size and abs(traj.times[i] - traj.times[0] - rel) < 1e-9:
            q_ref, v_ref = traj.positions[i], traj.velocities[i]  # on a sample: no interpolation
        else:
            q_ref, v_ref, _ = traj.sample(traj.times[0] + rel)
        ends = rel >= traj.duration - 1e-9 and not self._cmd_moving_end
        return q_ref, v_ref, ends

    def _step(self) -> None:
        dt = self.dt
        vmax, amax = self.limits.velocity, self.limits.acceleration
        q_ref, v_ref, ends = self._reference()
        v_exact = (q_ref - self._q) / dt
        a_exact = (v_exact - self._v) / dt
        ok = (np.abs(v_exact) <= vmax * (1 + 1e-9)) & (np.abs(a_exact) <= amax * (1 + 1e-6))
        exact = bool(ok.all())
        if exact:
            v_new = v_exact
        else:
            self.saturated_steps += 1
            e = q_ref - self._q
            v_des = v_ref + np.sign(e) * np.minimum(np.abs(e) / dt, np.sqrt(amax * np.abs(e)))
            a = np.clip((v_des - self._v) / dt, -amax, amax)
            v_lim = np.clip(self._v + a * dt, -vmax, vmax)
            v_new = np.where(ok, v_exact, v_lim)
        # followed exactly: at the reference itself (not q + v dt, a rounding off it; `_follow` relies on it)
        q_new = q_ref.copy() if exact else self._q + v_new * dt
        out = (q_new < self.limits.lower) | (q_new > self.limits.upper)
        if out.any():
            self.position_clamped_steps += 1
            q_new = np.clip(q_new, self.limits.lower, self.limits.upper)
            v_new = np.where(out, (q_new - self._q) / dt, v_new)
        self._a = (v_new - self._v) / dt
        self._q, self._v = q_new, v_new
        self._k += 1
        self._cmd_k += 1 if self._cmd is not None else 0
        self._evolve_error(1)
        self._remember(1)
        if ends:
            self._finish()

    def _finish(self) -> None:
        """The last sample of a command that ends at rest was reached: hold its position.

        (The servo's velocity is the mean over the last step, so a little above zero at the end of a
        move; the hold position's reference absorbs it within the limits.)
        """
        if self._cmd is not None:  # (always: only a running command ends)
            self._hold = self._cmd.end[0].copy()
        self._cmd, self._cmd_kind = None, ""
