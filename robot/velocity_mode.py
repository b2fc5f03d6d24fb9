"""`VelocityModeArm`: the host's side of an arm driven in velocity mode, as the paper drove the PA-10.

The arm's servo amplifier closes the velocity loops and saturates the torques; the host sends a
velocity command per joint every servo period (1 ms on the PA-10). This class is that host:
a `wiithrow.robot.host_arm.HostArm` (the interpolator, the commands, the idle test) whose
controller the hardware calls every period:

    v_cmd = v_ref(t) + K_p (q_ref(t) - q),    clipped to the velocity limits

with (q_ref, v_ref) the interpolator's state at the period's time t and q the encoders. No
friction or inertia feed-forward: the arm lags its reference by what its servo loop leaves, as a
real one does.

The hardware is anything that implements `VelocityInterface` (`host_arm.ServoInterface`, fed
velocities): the MuJoCo world's servo implements it (`wiithrow.app.worlds.mujoco.lab`); a real
PA-10 driver would, with its 1 kHz loop on the controller board's interface.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from wiithrow.robot.errors import RobotError
from wiithrow.robot.host_arm import HostArm, ServoController, ServoInterface
from wiithrow.robot.interface import Clock
from wiithrow.robot.model import ArmModel

__all__ = ["VelocityController", "VelocityInterface", "VelocityModeArm"]

#: The controller the hardware calls every period: (t, q, dq) -> velocity command (rad/s).
VelocityController = ServoController
#: The hardware of a velocity-mode arm: its servo is fed velocities (rad/s).
VelocityInterface = ServoInterface


class VelocityModeArm(HostArm):
    """An `Arm` over a velocity-mode servo (see the module docstring; the idle test and the
    tolerances are `HostArm`'s). `position_gain` K_p (1/s)."""

    def __init__(
        self,
        arm_model: ArmModel,
        clock: Clock,
        hardware: VelocityInterface,
        *,
        position_gain: float = 25.0,
        rate_hz: float = 1000.0,
        moving_threshold: float = 0.005,
        settle_tolerance_rad: float = 0.002,
        start_tolerance_rad: float = 0.01,
    ) -> None:
        if not (np.isfinite(position_gain) and position_gain >= 0):
            raise RobotError(f"position_gain must be >= 0, got {position_gain}")
        self.position_gain = float(position_gain)
        self._v_low = -arm_model.limits.velocity
        super().__init__(
            arm_model,
            clock,
            hardware,
            rate_hz=rate_hz,
            moving_threshold=moving_threshold,
            settle_tolerance_rad=settle_tolerance_rad,
            start_tolerance_rad=start_tolerance_rad,
        )

    def _control(self, t: float, q: NDArray[np.float64], dq: NDArray[np.float64]) -> NDArray[np.float64]:
        with self._lock:
            q_ref, v_ref = self._reference_at(t)
            v = v_ref + self.position_gain * (q_ref - q)
            # np.minimum/maximum, not np.clip: this runs every millisecond, and np.clip's dispatch
            # costs more than the arithmetic on seven joints
            self.last_command = np.minimum(np.maximum(v, self._v_low), self.limits.velocity)
            return self.last_command
