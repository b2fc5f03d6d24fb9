"""Streaming joint 1 at a wanted velocity: `Joint1Commander`.

Re-planning a Ruckig move every 10 ms costs 2-6 ms per call for the PA-10 (measured: `plan_move`
samples the whole move at 1 kHz), so the commander streams short trajectories instead
(`arm.command_trajectory`, `horizon_s` long, 1 ms samples, built in well under a millisecond):
joint 1's acceleration follows

    a = clip((v_want - v_ref) / tau, +-a_max),   changing at most at the jerk limit,

the velocity stays within +-v_max, the other joints hold still. Each new trajectory starts from
the previous one's state at that instant, so the reference is continuous; if the loop stops
sending, the arm finishes the last trajectory and brakes to rest by itself.

Each trajectory is built from a state at a known time (the reference now, or the measured state's
timestamp after a resync) on to `horizon_s` beyond the moment it is sent, and starts at that
moment: the 1 ms samples a held-up host let pass are dropped. Without that, a host held up
between reading the arm and commanding while joint 1 moves (a loaded CPU: 30-50 ms at 1 rad/s)
sends a trajectory that starts 0.03-0.05 rad behind the arm, which the arm refuses
(`StartMismatchError`), and so does every rebuild from a state read just as late. A wanted velocity is
also capped so that joint 1 can brake before its position limits (`brake_limit`).
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from wiithrow.clock import Clock
from wiithrow.robot import Arm, JointTrajectory, StartMismatchError
from wiithrow.robot.limits import JointLimits

#: How long (s) building a trajectory may take on a loaded host: it is built this much longer.
BUILD_ALLOWANCE_S = 0.02


def _clip(x: float, bound: float) -> float:
    """x limited to [-bound, bound] (plain floats: this runs for every 1 ms sample of a command)."""
    return min(max(float(x), -bound), bound)


class Joint1Commander:
    """Moves joint 1 at a wanted velocity by streaming short trajectories (see the module docstring).

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
        self._state_t = clock.now()  # the time of `_state`
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
        self._state_t = float(s.t)

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
            traj, t_start = self._build(v_want)
            try:
                self.arm.command_trajectory(traj)
            except StartMismatchError:
                if attempt == self.retries:
                    raise
                self.resync()
                self.resyncs += 1
                continue
            self._traj, self._t0 = traj, t_start
            return

    def _build(self, v_want: float) -> tuple[JointTrajectory, float]:
        """The trajectory of `command` and the time its first sample is for: built from the
        reference at its time (now; after a resync, the measured state's) and started now (module
        docstring)."""
        t_ref = self.clock.now() if self._traj is not None else self._state_t
        q, v, a = self.reference(t_ref)
        n = max(2, round((self.horizon + max(0.0, self.clock.now() - t_ref) + BUILD_ALLOWANCE_S) / self.dt) + 1)
        # the samples in plain floats (numpy's scalars cost several times more per operation; the
        # same IEEE arithmetic, so the very numbers)
        Q, V, A = [float(q)], [float(v)], [float(a)]
        dt, tau, a_max, jerk_step = self.dt, self.tau, self.a_max, self.j_max * self.dt
        wanted = _clip(v_want, self.v_max)
        for _ in range(1, n):
            q_k, v_k, a_k = Q[-1], V[-1], A[-1]
            target = self.brake_limit(q_k, v_k, wanted)
            a_goal = _clip((target - v_k) / tau, a_max)
            a_new = a_k + _clip(a_goal - a_k, jerk_step)
            v_new = _clip(v_k + a_new * dt, self.v_max)
            A.append((v_new - v_k) / dt)
            V.append(v_new)
            Q.append(q_k + 0.5 * (v_k + v_new) * dt)  # trapezoid: exact for constant acceleration
        skip = min(n - 2, max(0, math.floor((self.clock.now() - t_ref) / self.dt + 1e-9)))  # passed already
        n -= skip
        positions = np.repeat(self.q_hold[None], n, axis=0)
        positions[:, 0] = np.clip(Q[skip:], self.limits.lower[0], self.limits.upper[0])
        velocities = np.zeros_like(positions)
        velocities[:, 0] = V[skip:]
        accelerations = np.zeros_like(positions)
        accelerations[:, 0] = A[skip:]
        traj = JointTrajectory(np.arange(n, dtype=np.float64) * self.dt, positions, velocities, accelerations)
        return traj, t_ref + skip * self.dt

    def stop(self) -> None:
        self.arm.stop()
        self._traj = None
