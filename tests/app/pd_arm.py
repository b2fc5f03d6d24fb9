"""`PdArm`: a test double of a position-controlled arm whose controller is a joint PD on setpoints,
as a lab's or a vendor's model defines one, with or without the terms a controller may lack.

Per joint j, every servo period h (1 ms), with (q_s, v_s) the setpoint's position and velocity
(the host's trajectory, interpolated by a `SimulatedArm` as `VelocityModeArm` does) and g(q) the
arm's gravity torque (Pinocchio, from its model's inertials):

    tau_j = K_j (q_s - q) + D_j (f_v v_s - dq) + f_g g_j(q)          D_j = lag_s K_j
    J_j ddq_j = tau_j - g_j(q)                                        (J_j: the joint's own inertia)

`f_v` (velocity feed-forward) and `f_g` (gravity compensation) are 1 or 0. Without velocity
feed-forward the damping acts on the measured speed and the joint lags its setpoints by D / K =
`lag_s` at constant speed; without gravity compensation it sags by g / K at rest. The joints are
decoupled (the diagonal of the mass matrix at the start pose, at least `ROTOR_INERTIA`); the step
is exact for the linear part (the 2 x 2 system's matrix exponential), g held over it, so any
stiffness is stable. Enough of a plant to show a controller's missing terms, not a model of an arm.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import scipy.linalg
from numpy.typing import ArrayLike, NDArray

from wiithrow.clock import Clock, SimClock
from wiithrow.robot import ArmModel, JointState, JointTrajectory, StartMismatchError
from wiithrow.robot.simulated import SimulatedArm

#: The least inertia of a joint (kg m^2): a motor's rotor through its gear.
ROTOR_INERTIA = 0.1
#: The Panda's joint stiffness in the community MuJoCo model (menagerie's `panda.xml`: kp 4500,
#: 4500, 3500, 3500, 2000, 2000, 2000 N m/rad), what a lab's Panda runs on.
PANDA_STIFFNESS = (4500.0, 4500.0, 3500.0, 3500.0, 2000.0, 2000.0, 2000.0)
#: How far a commanded trajectory may start from the measured joints (rad), as the project's drivers.
START_TOLERANCE_RAD = 0.01


class PdArm:
    """An `Arm`: the PD controller of the module docstring on the arm `model`, on `clock`."""

    def __init__(
        self,
        model: ArmModel,
        clock: Clock,
        *,
        stiffness: ArrayLike,
        lag_s: float,
        gravity_compensation: bool,
        velocity_feedforward: bool,
        q0: ArrayLike | None = None,
        period_s: float = 0.001,
    ) -> None:
        self.model, self.clock, self.limits = model, clock, model.limits
        self.h = float(period_s)
        q_start = np.array(model.home if q0 is None else q0, dtype=float)
        self._data = model.model.createData()
        inertia = np.maximum(np.diag(pin.crba(model.model, self._data, q_start)), ROTOR_INERTIA)
        self.K = np.asarray(stiffness, dtype=float)
        self.D = float(lag_s) * self.K
        self.f_v, self.f_g = float(velocity_feedforward), float(gravity_compensation)
        # x' = A x + B u per joint, x = (q, dq), u = the force that is constant over a step
        self._phi = np.empty((model.nq, 2, 2))
        self._gamma = np.empty((model.nq, 2))
        for j in range(model.nq):
            m = np.zeros((3, 3))
            m[0, 1] = 1.0
            m[1, 0], m[1, 1], m[1, 2] = -self.K[j] / inertia[j], -self.D[j] / inertia[j], 1.0 / inertia[j]
            e = scipy.linalg.expm(m * self.h)
            self._phi[j], self._gamma[j] = e[:2, :2], e[:2, 2]
        self._t = float(clock.now())
        self._ref_clock = SimClock(self._t)
        self.interpolator = SimulatedArm(model, self._ref_clock, q0=q_start, start_tolerance_rad=1.0)
        self.q, self.dq = q_start.copy(), np.zeros(model.nq)
        for _ in range(50):  # start at rest where the controller holds it
            self.q = q_start - (1.0 - self.f_g) * self.gravity(self.q) / self.K

    def gravity(self, q: NDArray[np.float64]) -> NDArray[np.float64]:
        """The torque (N m) gravity puts on each joint at q."""
        return np.array(pin.computeGeneralizedGravity(self.model.model, self._data, q))

    def _advance(self) -> None:
        while self._t + self.h <= self.clock.now() + 1e-12:
            self._t += self.h
            self._ref_clock.advance(self.h)
            q_s, v_s = self.interpolator.ideal_qv()
            force = self.K * q_s + self.D * self.f_v * v_s + (self.f_g - 1.0) * self.gravity(self.q)
            q = self._phi[:, 0, 0] * self.q + self._phi[:, 0, 1] * self.dq + self._gamma[:, 0] * force
            self.dq = self._phi[:, 1, 0] * self.q + self._phi[:, 1, 1] * self.dq + self._gamma[:, 1] * force
            self.q = q

    def state(self) -> JointState:
        self._advance()
        return JointState(self._t, self.q.copy(), self.dq.copy())

    def command_position(self, q: ArrayLike) -> None:
        self._advance()
        self.interpolator.command_position(np.asarray(q, dtype=float))

    def command_trajectory(self, traj: JointTrajectory) -> None:
        self._advance()
        gap = np.abs(traj.positions[0] - self.q)
        if np.any(gap > START_TOLERANCE_RAD):
            j = int(np.argmax(gap))
            name = self.model.joint_names[j]
            raise StartMismatchError(
                f"the trajectory starts {gap[j]:.4f} rad from the arm at {name}", name, float(gap[j])
            )
        self.interpolator.command_trajectory(traj)

    def stop(self) -> None:
        self._advance()
        self.interpolator.stop()

    def is_moving(self) -> bool:
        self._advance()
        return self.interpolator.is_moving() or bool(np.any(np.abs(self.dq) > 0.005))

    def wait_until_idle(self, timeout: float) -> bool:
        deadline = self.clock.now() + timeout
        while self.is_moving():
            if self.clock.now() >= deadline:
                return False
            self.clock.sleep(0.01)
        return True
