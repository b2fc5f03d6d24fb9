"""The arm's servo amplifier in velocity mode (the PA-10's interface; every arm of the MuJoCo world
gets the same, its gains scaled to its own joints' inertia): a PI velocity loop per joint,
saturated at the joint's torque limit, run at the servo rate (1 kHz). Part of the simulated hardware, not of the
host: the host (`wiithrow.robot.velocity_mode.VelocityModeArm`) only sends velocity commands.

Per joint, every period h, with v_c the commanded and v the measured velocity:

    e = v_c - v
    tau = K_v (e + w_i s),        s <- s + e h          (s: the integral of the error)
    tau_sat = clip(tau, -tau_max, tau_max);  while saturated, s is not integrated further (anti-windup)

No friction or inertia feed-forward (the paper's set-up): the loop meets gravity, friction and the
arm's changing inertia with its integral, and lags. The gain follows from a bandwidth w_v (rad/s)
and the joint's inertia J (rotor and links at the home pose, as the manufacturer tunes it once):
K_v = J w_v, w_i = w_v / 5, so the closed velocity loop is about a first-order lag of time
constant 1 / w_v (a step of the command reaches 63 % after about 1 / w_v; the test measures it).

This class holds the loop's gains and its state (the integrals, the count of saturated periods);
the loop itself runs compiled, each period with the host's law and `mj_step`, in
`wiithrow.app.worlds.mujoco.cycle`.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike

#: The integral corner as a fraction of the bandwidth.
INTEGRAL_FRACTION = 0.2


class VelocityPI:
    """PI velocity loops with saturation for n joints: gains and state (see the module docstring)."""

    def __init__(self, inertia: ArrayLike, torque_limit: ArrayLike, bandwidth_rad_s: float, period_s: float) -> None:
        self.inertia = np.asarray(inertia, dtype=float)
        self.torque_limit = np.asarray(torque_limit, dtype=float)
        self.bandwidth = float(bandwidth_rad_s)
        self.period = float(period_s)
        self.gain = self.inertia * self.bandwidth  # K_v, N m s/rad
        self.integral_rate = INTEGRAL_FRACTION * self.bandwidth  # w_i, 1/s
        self.integral = np.zeros_like(self.inertia)  # s, rad
        self.counters = np.zeros(1, dtype=np.int64)  # [periods in which the torque saturated]

    @property
    def saturated_steps(self) -> int:
        """How many periods saturated the torque of some joint."""
        return int(self.counters[0])

    def reset(self) -> None:
        self.integral[:] = 0.0
