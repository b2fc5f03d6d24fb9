"""Deliberately bad arm drivers for the tests of `wiithrow check-driver`: the MuJoCo world's arm
driver (`wiithrow.app.worlds.mujoco.drivers:arm`) with one fault each, named in settings as a lab's
driver would be ("tests.app.bad_drivers:lagging_arm", ...):

* `lagging_arm`: follows every trajectory 50 ms late (the trajectory is held at its first sample
  for `LAG_S` before it starts, still sampled every millisecond), as a driver with a command queue
  50 ms deep would;
* `stop_ignoring_arm`: `stop()` does nothing: a running trajectory runs on to its end;
* `stale_arm`: `state()` reports the same sample (timestamp and joints) for `STALE_S` at a time,
  as a driver that reads a slow bus and caches the answer would;
* `echoing_arm`: never moves the arm; `state()` is the last command, exactly (a trajectory's
  sample due at the clock's now, a position at once; Stop freezes it), stamped now, as a driver
  that reports what it sent instead of what it measured would. It switches the hand's LED of the
  arm that stays where it is.

Everything else is the MuJoCo driver's: the faults are the only differences.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike

from wiithrow.app.settings import Settings
from wiithrow.app.worlds.mujoco.drivers import arm as mujoco_arm
from wiithrow.clock import Clock
from wiithrow.robot import Arm, ArmModel, JointState, JointTrajectory

#: How late the lagging driver follows its trajectories (s).
LAG_S = 0.05
#: How long the stale driver repeats a sample (s).
STALE_S = 0.1


class WrappedArm:
    """An `Arm` that passes everything to `inner` (the faults override one method each)."""

    def __init__(self, inner: Arm, clock: Clock) -> None:
        self.inner = inner
        self.clock = clock

    def state(self) -> JointState:
        return self.inner.state()

    def command_position(self, q: ArrayLike) -> None:
        self.inner.command_position(np.asarray(q, dtype=float))

    def command_trajectory(self, traj: JointTrajectory) -> None:
        self.inner.command_trajectory(traj)

    def stop(self) -> None:
        self.inner.stop()

    def is_moving(self) -> bool:
        return self.inner.is_moving()

    def wait_until_idle(self, timeout: float) -> bool:
        return self.inner.wait_until_idle(timeout)


def held(traj: JointTrajectory, seconds: float) -> JointTrajectory:
    """`traj` after `seconds` at its first sample (sampled at its own interval)."""
    dt = traj.dt or 0.001
    hold = np.arange(0.0, seconds - 1e-12, dt)
    n = hold.size
    return JointTrajectory(
        np.concatenate([hold, traj.times - traj.times[0] + seconds]),
        np.vstack([np.repeat(traj.positions[:1], n, axis=0), traj.positions]),
        np.vstack([np.zeros((n, traj.nq)), traj.velocities]),
        np.vstack([np.zeros((n, traj.nq)), traj.accelerations]),
    )


class LaggingArm(WrappedArm):
    def command_trajectory(self, traj: JointTrajectory) -> None:
        self.inner.command_trajectory(held(traj, LAG_S))


class StopIgnoringArm(WrappedArm):
    def stop(self) -> None:
        pass


class StaleArm(WrappedArm):
    def __init__(self, inner: Arm, clock: Clock) -> None:
        super().__init__(inner, clock)
        self._cached = inner.state()

    def state(self) -> JointState:
        if self.clock.now() - self._cached.t >= STALE_S:
            self._cached = self.inner.state()
        return self._cached


class EchoingArm(WrappedArm):
    """The echo of its commands (module docstring); the inner arm is never commanded."""

    def __init__(self, inner: Arm, clock: Clock) -> None:
        super().__init__(inner, clock)
        start = inner.state()
        self._traj: JointTrajectory | None = None
        self._t0 = 0.0
        self._q, self._dq = np.array(start.q, dtype=float), np.zeros_like(start.q)

    def _echo(self) -> tuple[np.ndarray, np.ndarray]:
        traj = self._traj
        if traj is None:
            return self._q, self._dq
        k = int(np.searchsorted(traj.times, self.clock.now() - self._t0, side="right")) - 1
        k = min(max(k, 0), traj.times.size - 1)  # the last sample sent so far
        return traj.positions[k].copy(), traj.velocities[k].copy()

    def state(self) -> JointState:
        q, dq = self._echo()
        return JointState(self.clock.now(), q, dq)

    def command_position(self, q: ArrayLike) -> None:
        self._traj, self._q, self._dq = None, np.array(q, dtype=float), np.zeros_like(self._q)

    def command_trajectory(self, traj: JointTrajectory) -> None:
        self._traj, self._t0 = traj, self.clock.now()

    def stop(self) -> None:
        self._q, self._dq = self._echo()
        self._traj, self._dq = None, np.zeros_like(self._dq)

    def is_moving(self) -> bool:
        return self._traj is not None and self.clock.now() - self._t0 < self._traj.duration

    def wait_until_idle(self, timeout: float) -> bool:
        deadline = self.clock.now() + timeout
        while self.is_moving():
            if self.clock.now() >= deadline:
                return False
            self.clock.sleep(0.01)
        return True

    def set_marker_led(self, on: bool) -> None:
        self.inner.set_marker_led(on)  # type: ignore[attr-defined]


def lagging_arm(model: ArmModel, clock: Clock, settings: Settings) -> LaggingArm:
    return LaggingArm(mujoco_arm(model, clock, settings), clock)


def stop_ignoring_arm(model: ArmModel, clock: Clock, settings: Settings) -> StopIgnoringArm:
    return StopIgnoringArm(mujoco_arm(model, clock, settings), clock)


def stale_arm(model: ArmModel, clock: Clock, settings: Settings) -> StaleArm:
    return StaleArm(mujoco_arm(model, clock, settings), clock)


def echoing_arm(model: ArmModel, clock: Clock, settings: Settings) -> EchoingArm:
    return EchoingArm(mujoco_arm(model, clock, settings), clock)


#: The capped driver's speed: this fraction of every joint's velocity limit (rad/s).
CAP_FRACTION = 1.0 / 3.0


def speed_capped_arm(model: ArmModel, clock: Clock, settings: Settings) -> Arm:
    """The MuJoCo arm whose drive is set to a third of the spec's velocity limits: its velocity
    commands are clipped there (`MujocoArm.velocity_limit`, the compiled law's), as a drive whose
    speed parameter was left at a third, or an arm with that much friction, would move."""
    arm = mujoco_arm(model, clock, settings)
    arm.velocity_limit = CAP_FRACTION * model.velocity_limit
    return arm
