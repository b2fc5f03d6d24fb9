"""`PositionModeArm`: the host's side of an arm whose servo takes joint position setpoints, a joint
PD loop without gravity compensation, the way vendors' and labs' models define their arms and
many real controllers run them.

The servo closes tau = K_p (q_set - q) - K_d dq per joint and saturates the torques; the host
sends a setpoint per joint every servo period. This class is that host: a
`wiithrow.robot.host_arm.HostArm` (the interpolator, the commands, the idle test) whose
controller the hardware calls every period:

    q_set = q_ref(t)                                   (raw setpoints: no feed-forward)
    q_set = q_ref + (tau_ff + K_d v_ref) / K_p         (`robot.feedforward.PDFeedForward`)

with (q_ref, v_ref, a_ref) the interpolator's state at the period's time t. Raw setpoints lag a
moving reference by K_d / K_p and sag under gravity by g / K_p; the feed-forward's velocity term
removes the lag, its inverse-dynamics term the sag and the inertial lag (`robot.feedforward`).

Idle: once the reference rests and every joint is slower than `moving_threshold`, and, when the
setpoints carry the inverse dynamics (the arm then comes to rest on its reference), within
`settle_tolerance_rad` of it. Without that term the arm is not required to reach the reference: a PD
servo holds it off by g(q) / K_p for as long as it stands there, and its approach is an exponential
of time constant about K_d / K_p (0.1 s on the arms this was written for), so a joint slower than
5 mrad/s is within about 0.5 mrad of where it comes to rest (an arm read at the very instant its
setpoint jumped has not started to move: only the reference's own moves are waited for then).

The hardware is anything that implements `PositionInterface` (`host_arm.ServoInterface`, fed
setpoints): the MuJoCo world's position servo (`wiithrow.app.worlds.mujoco.lab`); a real arm's
driver that streams joint positions at the servo rate would.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from wiithrow.robot.feedforward import PDFeedForward
from wiithrow.robot.host_arm import HostArm, ServoController, ServoInterface
from wiithrow.robot.interface import Clock
from wiithrow.robot.model import ArmModel

__all__ = ["PositionController", "PositionInterface", "PositionModeArm"]

#: The controller the hardware calls every period: (t, q, dq) -> position setpoint (rad).
PositionController = ServoController
#: The hardware of a position-mode arm: its servo is fed setpoints (rad).
PositionInterface = ServoInterface


class PositionModeArm(HostArm):
    """An `Arm` over a joint PD servo fed position setpoints (see the module docstring).
    `feedforward`: None for raw setpoints, else what makes them (`PDFeedForward`)."""

    def __init__(
        self,
        arm_model: ArmModel,
        clock: Clock,
        hardware: PositionInterface,
        *,
        feedforward: PDFeedForward | None = None,
        rate_hz: float = 1000.0,
        moving_threshold: float = 0.005,
        settle_tolerance_rad: float = 0.002,
        start_tolerance_rad: float = 0.01,
    ) -> None:
        self.feedforward = feedforward
        reaches = feedforward is not None and "inverse_dynamics" in feedforward.terms
        super().__init__(
            arm_model,
            clock,
            hardware,
            rate_hz=rate_hz,
            moving_threshold=moving_threshold,
            settle_tolerance_rad=settle_tolerance_rad if reaches else None,
            start_tolerance_rad=start_tolerance_rad,
        )

    @property
    def feedforward_terms(self) -> tuple[str, ...]:
        """The terms the setpoints carry beyond the reference (empty: raw setpoints)."""
        return () if self.feedforward is None else self.feedforward.terms

    def _control(self, t: float, q: NDArray[np.float64], dq: NDArray[np.float64]) -> NDArray[np.float64]:
        with self._lock:
            q_ref, v_ref = self._reference_at(t)
            if self.feedforward is None:
                self.last_command = q_ref.copy()
            else:
                self.last_command = self.feedforward.setpoints(q_ref, v_ref, self.interpolator.acceleration)
            return self.last_command
