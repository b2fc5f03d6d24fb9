"""What the MuJoCo world's arm actuators take, and the gains of the servo in the model: one of
`SERVO_KINDS`, found from the compiled model's actuators (a lab's MJCF defines its own) or set by
the settings (the project's model, `mujoco.arm_servo`).

* `torque`: MuJoCo `motor` actuators (gain 1, no bias); the project's amplifier (`servo.VelocityPI`,
  the PA-10's PI velocity loops) turns the host's velocity command into their torques: the
  project's model by default (`arm_servo` "pi_velocity");
* `velocity`: MuJoCo `velocity` actuators, force = K_v (ctrl - dq): a P velocity loop in the model
  (a vendor's velocity interface); the host's velocity command is their ctrl;
* `position`: a joint PD on position setpoints, force = K_p (ctrl - q) - K_d dq: MuJoCo `position`
  actuators, or `general` ones with that affine bias; no gravity compensation unless the model
  adds it. The host's setpoint is their ctrl (`wiithrow.robot.position_mode`). The project's model
  gets them with `arm_servo` "pd_position": K_p = J w^2 with J each joint's inertia at home (rotor
  and hand included, as a vendor tunes once) and w = 2 pi `pd_bandwidth_hz`; K_d = K_p `pd_lag_s`,
  so raw setpoints lag a moving reference by `pd_lag_s` (`robot.feedforward`).

Every actuator of the arm must be of one kind, on its joint (transmission `joint`, gear 1), with
no activation dynamics: anything else is one line naming the actuator (a lab's MJCF).

`position_feedforward`: what the shipped position-mode driver adds to its setpoints
(`mujoco.feedforward`: none, the velocity term, or the inverse dynamics of the arm's model with the
rotors' inertia as the model states them: `robot.feedforward`).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import mujoco
import numpy as np
from numpy.typing import NDArray

from wiithrow.app.errors import AppError
from wiithrow.robot import ArmModel
from wiithrow.robot.feedforward import InverseDynamics, PDFeedForward

#: The kinds, in the order of `cycle.SERVO_TORQUE`, `SERVO_VELOCITY`, `SERVO_POSITION`.
SERVO_KINDS = ("torque", "velocity", "position")
#: The feed-forward choices of the shipped position-mode driver (`mujoco.feedforward`) and the
#: `robot.feedforward` terms each adds.
FEEDFORWARD_CHOICES = {"none": (), "velocity": ("velocity",), "inverse_dynamics": ("velocity", "inverse_dynamics")}

#: How long (s) a servo in the model (a velocity or a position servo) holds the arm before the
#: world's clock starts: it was powered on before (a PD servo without gravity compensation sags by
#: g / K_p in about 0.3 s, three of its time constants K_d / K_p).
SETTLE_AT_POWER_ON_S = 1.0

#: How close (relative) an affine bias must be to -K_p q - K_d dq (or -K_v dq) to be read as one.
_GAIN_MATCH = 1e-9


@dataclass(frozen=True)
class ServoGains:
    """The servo in the model: its kind (`SERVO_KINDS`) and per joint K_p (N m/rad), K_d (N m s/rad;
    for a velocity servo its K_v), zeros for a torque motor."""

    kind: str
    kp: NDArray[np.float64]
    kd: NDArray[np.float64]

    @property
    def index(self) -> int:
        """The kind's number in the compiled loop (`cycle.SERVO_TORQUE`, ...)."""
        return SERVO_KINDS.index(self.kind)


def servo_of(
    model: mujoco.MjModel,
    actuators: Sequence[int] | NDArray[np.intp],
    joints: Sequence[int] | NDArray[np.intp],
    where: str,
) -> ServoGains:
    """The kind and gains of the arm's `actuators` (ids, one per arm joint of `joints`, ids) in a
    compiled model; AppError naming the first actuator that is none of the kinds, or drives
    another joint, or of another kind than the first (`where`: whose model)."""
    kinds, kp, kd = [], [], []
    for actuator, joint in zip(actuators, joints):
        name = mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_ACTUATOR, actuator)
        if (
            model.actuator_trntype[actuator] != mujoco.mjtTrn.mjTRN_JOINT
            or model.actuator_trnid[actuator, 0] != joint
            or not math.isclose(model.actuator_gear[actuator, 0], 1.0)
        ):
            raise AppError(f"{where}: actuator {name!r} must drive its arm joint directly (joint transmission, gear 1)")
        if model.actuator_dyntype[actuator] != mujoco.mjtDyn.mjDYN_NONE or model.actuator_gaintype[actuator] != 0:
            raise AppError(
                f"{where}: actuator {name!r} has activation dynamics or a non-fixed gain: not a servo the drivers know"
            )
        gain = float(model.actuator_gainprm[actuator, 0])
        bias = model.actuator_biasprm[actuator, :3]
        biased = model.actuator_biastype[actuator] == mujoco.mjtBias.mjBIAS_AFFINE
        tol = _GAIN_MATCH * max(1.0, abs(gain))
        if not biased and math.isclose(gain, 1.0):
            found = ("torque", 0.0, 0.0)
        elif biased and gain > 0 and abs(bias[0]) <= tol and abs(bias[1] + gain) <= tol and bias[2] <= 0:
            found = ("position", gain, -float(bias[2]))
        elif biased and gain > 0 and abs(bias[0]) <= tol and abs(bias[1]) <= tol and abs(bias[2] + gain) <= tol:
            found = ("velocity", 0.0, gain)
        else:
            raise AppError(
                f"{where}: actuator {name!r} is none of a motor (gain 1), a position servo (bias 0, -kp, -kv) or a "
                f"velocity servo (bias 0, 0, -kv): gain {gain:g}, bias {bias.tolist()}"
            )
        kinds.append(found[0])
        kp.append(found[1])
        kd.append(found[2])
        if kinds[-1] != kinds[0]:
            raise AppError(
                f"{where}: actuator {name!r} is a {kinds[-1]} servo, the arm's first a {kinds[0]} servo: one kind per arm"
            )
    return ServoGains(kinds[0], np.array(kp), np.array(kd))


def make_pd_actuator(actuator: mujoco.MjsActuator, lower: float, upper: float, torque_limit: float) -> None:
    """A joint PD position actuator in the project's model (gains set after compiling:
    `tune_pd`): setpoints within the joint's range, force within its torque limit."""
    actuator.set_to_position(kp=1.0, kv=0.0)
    actuator.ctrllimited = mujoco.mjtLimited.mjLIMITED_TRUE
    actuator.ctrlrange = np.array([lower, upper])
    actuator.forcelimited = mujoco.mjtLimited.mjLIMITED_TRUE
    actuator.forcerange = np.array([-torque_limit, torque_limit])


def power_on(model: mujoco.MjModel, data: mujoco.MjData, arm_ctrl: slice, hold: NDArray[np.float64]) -> None:
    """A servo in the model powered on and settled (`SETTLE_AT_POWER_ON_S`) with its command `hold`
    (a position servo's setpoint, a velocity servo's 0), before the world's clock starts."""
    data.ctrl[arm_ctrl] = hold
    for _ in range(round(SETTLE_AT_POWER_ON_S / model.opt.timestep)):
        mujoco.mj_step(model, data)
    data.time = 0.0


def home_inertia(
    model: mujoco.MjModel, joint_qpos: NDArray[np.intp], joint_dof: NDArray[np.intp], home: NDArray[np.float64]
) -> NDArray[np.float64]:
    """Each arm joint's inertia (kg m^2: the diagonal of the mass matrix, rotor included) at `home`."""
    data = mujoco.MjData(model)
    data.qpos[joint_qpos] = home
    mujoco.mj_forward(model, data)
    M = np.zeros((model.nv, model.nv))
    mujoco.mj_fullM(model, data, M)
    return np.diag(M)[joint_dof].copy()


def tune_pd(
    model: mujoco.MjModel, actuators: NDArray[np.intp], inertia: NDArray[np.float64], bandwidth_hz: float, lag_s: float
) -> ServoGains:
    """Set the project's PD actuators' gains in the compiled `model` (module docstring: K_p = J w^2,
    K_d = K_p lag) from each joint's `inertia` at home (kg m^2); the gains."""
    w = 2.0 * math.pi * bandwidth_hz
    kp = np.asarray(inertia, dtype=float) * w * w
    kd = kp * lag_s
    for a, p, d in zip(actuators, kp, kd):
        model.actuator_gainprm[a, 0] = p
        model.actuator_biasprm[a, :3] = (0.0, -p, -d)
    return ServoGains("position", kp, kd)


def position_feedforward(
    choice: str, gains: ServoGains, arm: ArmModel, rotor_inertia: NDArray[np.float64]
) -> PDFeedForward | None:
    """The shipped position-mode driver's feed-forward (`FEEDFORWARD_CHOICES[choice]`), None for
    raw setpoints. The inverse dynamics are the planner's model of the arm (its URDF's inertials)
    and the rotors' inertia the model states (what a maker's data sheet gives a driver)."""
    terms = FEEDFORWARD_CHOICES[choice]
    if not terms:
        return None
    dynamics = InverseDynamics(arm, rotor_inertia=rotor_inertia) if "inverse_dynamics" in terms else None
    return PDFeedForward(gains.kp, gains.kd, terms, dynamics)
