"""`HostArm`: the host's side of an arm whose servo the host feeds every period, whatever it feeds
it: a velocity command (`wiithrow.robot.velocity_mode.VelocityModeArm`, the PA-10's interface) or a
position setpoint (`wiithrow.robot.position_mode.PositionModeArm`, a joint PD servo's).

Owns what both share: an `wiithrow.robot.interface.Arm` whose commands (moves, trajectories,
stops) run through an interpolator, and the idle test. The interpolator is a `SimulatedArm` on a
private clock that the subclass's controller moves to each period's time (`_reference_at`): the
same Ruckig moves and brakes, exact following of a feasible trajectory, continuation of a
trajectory that ends in motion (a throw's release) into a brake, and the hold position at rest.

The hardware is anything that implements `ServoInterface`: `read()` the encoders (a simulation
catches up with its clock first) and `attach(controller)`, after which it calls
`controller(t, q, dq)` every period and sends what it returns to the servo.

Thread-safety: the controller runs in whichever thread makes the hardware step; commands hold a
lock of their own and never call the hardware while holding it.
"""

from __future__ import annotations

import threading
from collections.abc import Callable
from typing import Protocol

import numpy as np
from numpy.typing import ArrayLike, NDArray

from wiithrow.clock import SimClock
from wiithrow.robot.errors import RobotError, StartMismatchError
from wiithrow.robot.interface import Clock, JointState
from wiithrow.robot.model import ArmModel
from wiithrow.robot.simulated import SimulatedArm
from wiithrow.robot.trajectory import JointTrajectory

__all__ = ["HostArm", "ServoController", "ServoInterface"]

#: The controller the hardware calls every period: (t, q, dq) -> the servo's command per joint
#: (a velocity in rad/s, or a position setpoint in rad, as the servo takes).
ServoController = Callable[[float, NDArray[np.float64], NDArray[np.float64]], NDArray[np.float64]]


class ServoInterface(Protocol):
    """The hardware of an arm fed every period (see the module docstring)."""

    def read(self) -> JointState:
        """The encoders now."""
        ...

    def attach(self, controller: ServoController | None) -> None:
        """Call `controller` every servo period from now on (None: rest)."""
        ...


class HostArm:
    """An `Arm` over a servo fed every period (see the module docstring); a subclass gives the
    controller (`_control`).

    `rate_hz` the servo rate; the arm is idle once its reference rests, every joint is slower
    than `moving_threshold` (rad/s) and, unless `settle_tolerance_rad` is None, within it of the
    reference (a servo without friction feed-forward closes the last milliradians slowly, and a
    throw planned from a pose the arm then creeps away from would start elsewhere);
    `start_tolerance_rad`: how far a commanded trajectory may start from the measured position.
    """

    def __init__(
        self,
        arm_model: ArmModel,
        clock: Clock,
        hardware: ServoInterface,
        *,
        rate_hz: float = 1000.0,
        moving_threshold: float = 0.005,
        settle_tolerance_rad: float | None = 0.002,
        start_tolerance_rad: float = 0.01,
    ) -> None:
        self.arm_model = arm_model
        self.limits = arm_model.limits
        self.clock = clock
        self.hardware = hardware
        self.moving_threshold = float(moving_threshold)
        self.settle_tolerance_rad = None if settle_tolerance_rad is None else float(settle_tolerance_rad)
        self.start_tolerance_rad = float(start_tolerance_rad)
        self._lock = threading.RLock()
        state = hardware.read()
        self._ref_clock = SimClock(state.t)
        q0 = np.clip(state.q, self.limits.lower, self.limits.upper)
        self.interpolator = SimulatedArm(arm_model, self._ref_clock, rate_hz=rate_hz, q0=q0)
        self.last_command = np.zeros(arm_model.nq)
        hardware.attach(self._control)

    # ----- the controller (called by the hardware every period) ---------------------------------

    def _control(self, t: float, q: NDArray[np.float64], dq: NDArray[np.float64]) -> NDArray[np.float64]:
        raise NotImplementedError

    def _reference_at(self, t: float) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """The interpolator's (q_ref, v_ref) at the period's time `t`, its clock moved there first
        (the arrays are the interpolator's, not copies: read them, do not keep them). Hold the lock."""
        lag = t - self._ref_clock.now()
        if lag > 0:
            self._ref_clock.advance(lag)
        return self.interpolator.ideal_qv()

    def reference(self) -> JointState:
        """The interpolator's state at the last servo period (what the arm is told to be at)."""
        with self._lock:
            return self.interpolator.ideal_state()

    # ----- Arm protocol -------------------------------------------------------------------------

    def state(self) -> JointState:
        """The encoders now."""
        return self.hardware.read()

    def command_position(self, q: ArrayLike) -> None:
        """A jerk-limited move to `q` from the reference's state (LimitError outside the limits)."""
        self.hardware.read()
        with self._lock:
            self.interpolator.command_position(np.asarray(q, dtype=float))

    def command_trajectory(self, traj: JointTrajectory) -> None:
        """Follow `traj` from now; its first sample must be within `start_tolerance_rad` of the
        measured joints (else `StartMismatchError`, and nothing moves)."""
        if not isinstance(traj, JointTrajectory):
            raise RobotError(f"command_trajectory needs a JointTrajectory, got {type(traj).__name__}")
        measured = self.hardware.read()
        gap = np.abs(traj.positions[0] - measured.q)
        if np.any(gap > self.start_tolerance_rad):
            j = int(np.argmax(gap))
            name = self.limits.names[j]
            raise StartMismatchError(
                f"the trajectory starts {gap[j]:.4f} rad away from the arm at joint {name}; plan it from the "
                "arm's current state",
                name,
                float(gap[j]),
            )
        with self._lock:
            self.interpolator.command_trajectory(traj)

    def stop(self) -> None:
        """Brake the reference to rest within the limits; the servo follows."""
        self.hardware.read()
        with self._lock:
            self.interpolator.stop()

    def is_moving(self) -> bool:
        """True while the reference moves, or the arm has not settled on it (see the class docstring)."""
        measured = self.hardware.read()
        with self._lock:
            busy = self.interpolator.is_moving()
            reference = self.interpolator.ideal_qv()[0]  # (read here, not kept: no copy)
        tolerance = self.settle_tolerance_rad
        return (
            busy
            or bool(np.count_nonzero(np.abs(measured.dq) > self.moving_threshold))  # (np.any, as a C call)
            or (tolerance is not None and bool(np.count_nonzero(np.abs(measured.q - reference) > tolerance)))
        )

    def wait_until_idle(self, timeout: float) -> bool:
        """Sleep on the clock (10 ms at a time) until idle; False if `timeout` s passed first."""
        deadline = self.clock.now() + max(0.0, float(timeout))
        while self.is_moving():
            remaining = deadline - self.clock.now()
            if remaining <= 0:
                return False
            self.clock.sleep(min(remaining, 0.01))
        return True
