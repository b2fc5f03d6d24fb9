"""Feed-forward for an arm whose controller takes joint position setpoints: the torque a planned
trajectory needs, from the arm's model (Pinocchio's recursive Newton-Euler algorithm, RNEA), and
the setpoint correction that makes a joint PD servo deliver it.

Many arms are driven through a joint PD loop on position setpoints, the way vendors' and labs'
MuJoCo models define it (`position` actuators, or `general` ones with a bias) and many real
controllers run it:

    tau = K_p (q_set - q) - K_d dq          (per joint; no gravity compensation)

Sent the plan's positions as they are (q_set = q_ref), such a joint lags a moving reference by
K_d / K_p seconds (the damping acts on the measured velocity, not on the error) and sags under
gravity by g(q) / K_p. At perfect tracking (q = q_ref, dq = v_ref) the loop must produce the
inverse dynamics of the plan, tau_ff = M(q) a + C(q, v) v + g(q) (+ the rotor inertia's J_m a),
so the setpoint that gets it is

    q_set = q_ref + (tau_ff + K_d v_ref) / K_p

`K_d v_ref / K_p` is the velocity term (it removes the lag), `tau_ff / K_p` the torque term (the
sag and the inertial lag). `InverseDynamics` computes tau_ff from an `ArmModel` (the URDF's
inertials, plus a payload on the flange: the hand and the ball); `pd_setpoints` turns (q, v,
tau) into setpoints; `PDFeedForward` does both for a trajectory's rows. A lab's own driver calls
them with its controller's gains; the MuJoCo world's position-mode driver does
(`wiithrow.app.worlds.mujoco.devices`).

The model is the planner's: a lab's arm differs from it by its real masses, friction and
tolerances, which the feed-forward does not know (what is left is the servo's to correct).
Units: rad, rad/s, rad/s^2, N m; K_p in N m/rad, K_d in N m s/rad.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import pinocchio as pin
from numpy.typing import ArrayLike, NDArray

from wiithrow.robot.errors import RobotError
from wiithrow.robot.model import ArmModel

__all__ = ["FEEDFORWARD_TERMS", "InverseDynamics", "PDFeedForward", "Payload", "pd_setpoints"]

#: The terms a PD feed-forward may add: the controller's damping on the reference velocity
#: ("velocity"), and the arm's inverse dynamics ("inverse_dynamics": gravity, Coriolis, inertia).
FEEDFORWARD_TERMS = ("velocity", "inverse_dynamics")

Floats = NDArray[np.float64]


@dataclass(frozen=True)
class Payload:
    """A point mass carried beyond the flange: `mass_kg` (kg) at `offset_m` (m) along the flange's
    z axis (the hand and the ball, as one mass at their centre)."""

    mass_kg: float
    offset_m: float = 0.0

    def __post_init__(self) -> None:
        if not (np.isfinite(self.mass_kg) and 0.0 <= self.mass_kg <= 100.0):
            raise RobotError(f"a payload's mass must be 0-100 kg, got {self.mass_kg}")
        if not (np.isfinite(self.offset_m) and abs(self.offset_m) <= 2.0):
            raise RobotError(f"a payload's offset must be within 2 m of the flange, got {self.offset_m}")


class InverseDynamics:
    """tau = RNEA(q, v, a) of `arm`'s model (module docstring), with `payload` added to the link
    that carries the flange and `rotor_inertia` (kg m^2 per joint, the rotors reflected through
    their gears, which a URDF does not carry) times a added per joint. Not thread-safe: one per
    thread (it owns its Pinocchio data)."""

    def __init__(
        self, arm: ArmModel, *, payload: Payload | None = None, rotor_inertia: ArrayLike | None = None
    ) -> None:
        self.arm = arm
        self.model = model = pin.Model(arm.model)  # a copy: the payload must not change the arm's kinematics' model
        if payload is not None and payload.mass_kg > 0.0:
            frame = model.frames[model.getFrameId("flange")]
            placement = frame.placement * pin.SE3(np.eye(3), np.array([0.0, 0.0, payload.offset_m]))
            point = pin.Inertia(payload.mass_kg, np.zeros(3), np.zeros((3, 3)))
            model.inertias[frame.parentJoint] = model.inertias[frame.parentJoint] + placement.act(point)
        self.data = model.createData()
        self.rotor_inertia = np.zeros(arm.nq) if rotor_inertia is None else np.asarray(rotor_inertia, dtype=float)
        if self.rotor_inertia.shape != (arm.nq,) or not np.isfinite(self.rotor_inertia).all():
            raise RobotError(f"rotor_inertia needs {arm.nq} finite values (kg m^2), got {self.rotor_inertia.shape}")

    def torque(self, q: ArrayLike, v: ArrayLike, a: ArrayLike) -> Floats:
        """The joint torques (N m) that move the model along (q, v, a): one row (nq,) or many rows
        (m, nq) at once (each row RNEA's)."""
        Q, V, A = (np.atleast_2d(np.asarray(x, dtype=float)) for x in (q, v, a))
        if not Q.shape == V.shape == A.shape or Q.shape[1] != self.arm.nq:
            raise RobotError(f"q, v and a must be rows of {self.arm.nq} joints, got {Q.shape}, {V.shape}, {A.shape}")
        out = np.empty_like(Q)
        model, data = self.model, self.data
        for i in range(Q.shape[0]):
            out[i] = pin.rnea(model, data, Q[i], V[i], A[i])
        out += A * self.rotor_inertia
        return out[0] if np.ndim(q) == 1 else out

    def gravity(self, q: ArrayLike) -> Floats:
        """The torques (N m) that hold the model still at `q` (nq,)."""
        return np.asarray(pin.computeGeneralizedGravity(self.model, self.data, np.asarray(q, dtype=float)), dtype=float)


def pd_setpoints(q_ref: ArrayLike, v_ref: ArrayLike, tau_ff: ArrayLike | None, kp: ArrayLike, kd: ArrayLike) -> Floats:
    """Position setpoints (rad) for a joint PD servo tau = K_p (q_set - q) - K_d dq that deliver
    `tau_ff` (N m; None: no torque term) while the arm follows (q_ref, v_ref):
    q_set = q_ref + (tau_ff + K_d v_ref) / K_p (module docstring). Rows or one row; `kp`, `kd` one
    value per joint (N m/rad, N m s/rad; `kd` zeros: no velocity term)."""
    kp_ = np.asarray(kp, dtype=float)
    if not (np.isfinite(kp_).all() and (kp_ > 0).all()):
        raise RobotError(f"a PD servo's K_p must be positive and finite, got {kp_}")
    torque: Floats = np.asarray(kd, dtype=float) * np.asarray(v_ref, dtype=float)
    if tau_ff is not None:
        torque = torque + np.asarray(tau_ff, dtype=float)
    setpoints: Floats = np.asarray(q_ref, dtype=float) + torque / kp_
    return setpoints


class PDFeedForward:
    """The setpoints of a trajectory for a joint PD servo (`pd_setpoints`) with the terms named in
    `terms` (`FEEDFORWARD_TERMS`; empty: raw setpoints q_set = q_ref). `kp`, `kd` (N m/rad,
    N m s/rad, per joint): the servo's gains; `dynamics`: the inverse dynamics, needed for the
    "inverse_dynamics" term."""

    def __init__(
        self,
        kp: ArrayLike,
        kd: ArrayLike,
        terms: Sequence[str] = FEEDFORWARD_TERMS,
        dynamics: InverseDynamics | None = None,
    ) -> None:
        unknown = sorted(set(terms) - set(FEEDFORWARD_TERMS))
        if unknown:
            raise RobotError(f"unknown feed-forward term(s) {unknown}; known: {list(FEEDFORWARD_TERMS)}")
        if "inverse_dynamics" in terms and dynamics is None:
            raise RobotError("the inverse_dynamics feed-forward needs the arm's InverseDynamics")
        self.kp = np.asarray(kp, dtype=float)
        self.kd = np.asarray(kd, dtype=float) if "velocity" in terms else np.zeros_like(self.kp)
        self.dynamics = dynamics if "inverse_dynamics" in terms else None
        self.terms = tuple(t for t in FEEDFORWARD_TERMS if t in terms)
        pd_setpoints(np.zeros_like(self.kp), np.zeros_like(self.kp), None, self.kp, self.kd)  # checks the gains

    def setpoints(self, q_ref: ArrayLike, v_ref: ArrayLike, a_ref: ArrayLike) -> Floats:
        """q_set for the rows (or one row) of the reference (rad, rad/s, rad/s^2)."""
        tau = None if self.dynamics is None else self.dynamics.torque(q_ref, v_ref, a_ref)
        return pd_setpoints(q_ref, v_ref, tau, self.kp, self.kd)
