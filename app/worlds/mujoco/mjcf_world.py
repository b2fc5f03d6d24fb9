"""The MuJoCo world's model: the project's, built from the arm's URDF (`model.build_model`), or a
lab's own MJCF named by the settings (`wiithrow.app.mjcf_settings.MjcfSettings`), found by the
names its mapping gives and made into the same `model.BuiltModel`, so that the lab, the devices
and the drivers run it as they run the project's.

What is taken from the lab's model as it is: every body, joint, actuator, contact and option but
the timestep, which becomes the servo period (`mujoco.timestep_s`, 1 ms: the host's rate); the
arm's servo (its actuators: a motor, a velocity or a position servo, `arm_servo.servo_of`), its
joints' armature, damping and friction, its hand, ball, floor and table. No tolerance is drawn
(the `mujoco` sigmas are the project's model's): the lab's model differs from the spec's URDF by
its own. What the world adds: the target's and the landing marker's LEDs (sites in the world,
unless the model has `target_led` and `landing_led`), the contact sensors of the ball with each
pad, the floor and the table (`BuiltModel.pad_sensors`, `surface_sensors`), which read the state
and change nothing, and the simulated operator's hand (`BuiltModel.operator_hold`): a weld of the
ball's centre to the seat, on while the operator puts a ball in the hand and until both pads touch
it, as a person holds a ball in a slow hand's jaws until they close.

Checked before anything runs, each in one line naming the mapping's key: every name is an element
of the model of the right kind; the arm's joints are hinges, contiguous in the model's joints as
are its actuators; joint 1 turns about the base's vertical axis through its origin (within
`AXIS_TOLERANCE_RAD` and `ORIGIN_TOLERANCE_M`: a lab's model is a tolerance off its URDF, not
another arm); the ball is a body with a free joint and a sphere; the table is a mocap body with a
box; the arm's actuators state their torque limits.
"""

from __future__ import annotations

import math

import mujoco
import numpy as np
from numpy.typing import NDArray

from wiithrow.app.errors import AppError
from wiithrow.app.mjcf_settings import MjcfSettings
from wiithrow.app.settings import Settings
from wiithrow.app.worlds.mujoco import params
from wiithrow.app.worlds.mujoco.arm_servo import home_inertia, servo_of
from wiithrow.app.worlds.mujoco.model import BuiltModel, build_model
from wiithrow.robot import ArmModel, RobotError

#: How far joint 1's axis may lean from the base's z axis (rad), and its origin lie off it (m).
AXIS_TOLERANCE_RAD = 0.05
ORIGIN_TOLERANCE_M = 0.01

_J, _B, _G, _S, _A = (
    mujoco.mjtObj.mjOBJ_JOINT,
    mujoco.mjtObj.mjOBJ_BODY,
    mujoco.mjtObj.mjOBJ_GEOM,
    mujoco.mjtObj.mjOBJ_SITE,
    mujoco.mjtObj.mjOBJ_ACTUATOR,
)


def build_world(settings: Settings) -> BuiltModel:
    """The world's model: the lab's MJCF when the settings name one, else the project's."""
    if settings.mjcf is None:
        return build_model(settings)
    return build_mjcf_model(settings)


def build_mjcf_model(settings: Settings) -> BuiltModel:
    """The lab's MJCF of `settings.mjcf` as a `BuiltModel` (module docstring); AppError in one line."""
    mapping = settings.mjcf
    assert mapping is not None
    try:
        arm = settings.load_arm()
    except RobotError as exc:
        raise AppError(str(exc)) from None
    if len(mapping.arm_joints) != arm.nq:
        raise AppError(f"mjcf.arm_joints names {len(mapping.arm_joints)} joints for arm {arm.name!r}'s {arm.nq}")
    path = mapping.path()
    try:
        spec = mujoco.MjSpec.from_file(str(path))
    except ValueError as exc:
        raise AppError(f"mjcf.file {path}: not a model MuJoCo reads ({' '.join(str(exc).split())})") from None
    spec.option.timestep = settings.mujoco.timestep_s
    _check_names(spec, mapping)
    ball_geom, table_geom = _name_geoms(spec, mapping)
    for led in ("target_led", "landing_led"):
        if spec.site(led) is None:
            spec.worldbody.add_site(name=led, pos=[3.0, 3.0, 0.0], size=[0.01])
    # the simulated operator's hand: holds the ball on the seat until both pads touch it (`BuiltModel.operator_hold`)
    spec.body(mapping.ball).add_site(name="wiithrow_ball_centre", size=[0.002])
    spec.add_equality(
        type=mujoco.mjtEq.mjEQ_WELD,
        objtype=_S,
        name1="wiithrow_ball_centre",
        name2=mapping.ball_seat,
        active=False,
        name="wiithrow_operator_hold",
    )
    sensed = (*mapping.pads, mapping.floor, table_geom)
    for i, other in enumerate(sensed):
        sensor = spec.add_sensor(
            name=f"wiithrow_ball_contact_{i}",
            type=mujoco.mjtSensor.mjSENS_CONTACT,
            objtype=_G,
            objname=ball_geom,
            reftype=_G,
            refname=other,
        )
        sensor.intprm[0] = 1 << int(mujoco.mjtConDataField.mjCONDATA_FOUND)
        sensor.intprm[1] = 0
        sensor.intprm[2] = 1
    try:
        model = spec.compile()
    except ValueError as exc:
        raise AppError(f"mjcf.file {path}: MuJoCo cannot compile it ({' '.join(str(exc).split())})") from None
    return _built(model, mapping, arm, settings, ball_geom, table_geom, sensed)


def _check_names(spec: mujoco.MjSpec, mapping: MjcfSettings) -> None:
    """AppError naming the first of the mapping's names that is not an element of its kind in
    the model (before the world adds what refers to them: its sensors, the operator's hold)."""
    kinds = (
        ("arm_joints", spec.joint, "joint"),
        ("arm_actuators", spec.actuator, "actuator"),
        ("finger_joints", spec.joint, "joint"),
        ("finger_actuators", spec.actuator, "actuator"),
        ("pads", spec.geom, "geom"),
        ("floor", spec.geom, "geom"),
        ("ball_seat", spec.site, "site"),
        ("marker_led", spec.site, "site"),
    )
    for key, find, what in kinds:
        value = getattr(mapping, key)
        names = (value,) if isinstance(value, str) else value
        for i, name in enumerate(names):
            if find(name) is None:
                label = f"mjcf.{key}" if isinstance(value, str) else f"mjcf.{key}[{i}]"
                raise AppError(f"{label} {name!r} is not a {what} of the lab's MJCF")


def _name_geoms(spec: mujoco.MjSpec, mapping: MjcfSettings) -> tuple[str, str]:
    """The names of the ball's sphere and the table's box (named here when the model left them unnamed)."""
    found = []
    for key, kind in (("ball", mujoco.mjtGeom.mjGEOM_SPHERE), ("table", mujoco.mjtGeom.mjGEOM_BOX)):
        body = spec.body(getattr(mapping, key))
        if body is None:
            raise AppError(f"mjcf.{key} {getattr(mapping, key)!r} is not a body of the lab's MJCF")
        geom = next((g for g in body.geoms if g.type == kind), None)
        if geom is None:
            raise AppError(f"mjcf.{key} {body.name!r} has no {'sphere' if key == 'ball' else 'box'} geom")
        if not geom.name:
            geom.name = f"wiithrow_{key}"
        found.append(geom.name)
    return found[0], found[1]


def _ids(model: mujoco.MjModel, kind: mujoco.mjtObj, names: tuple[str, ...], key: str, what: str) -> NDArray[np.intp]:
    out = []
    for i, name in enumerate(names):
        index = mujoco.mj_name2id(model, kind, name)
        if index < 0:
            label = f"mjcf.{key}[{i}]" if len(names) > 1 or key.endswith("s") else f"mjcf.{key}"
            raise AppError(f"{label} {name!r} is not a {what} of the lab's MJCF")
        out.append(index)
    return np.array(out, dtype=np.intp)


def _built(
    model: mujoco.MjModel,
    mapping: MjcfSettings,
    arm: ArmModel,
    settings: Settings,
    ball_geom: str,
    table_geom: str,
    sensed: tuple[str, ...],
) -> BuiltModel:
    joints = _ids(model, _J, mapping.arm_joints, "arm_joints", "joint")
    if any(model.jnt_type[j] != mujoco.mjtJoint.mjJNT_HINGE for j in joints):
        raise AppError("mjcf.arm_joints must be hinge joints (the arm's are revolute)")
    actuators = _ids(model, _A, mapping.arm_actuators, "arm_actuators", "actuator")
    fingers = _ids(model, _J, mapping.finger_joints, "finger_joints", "joint")
    finger_actuators = _ids(model, _A, mapping.finger_actuators, "finger_actuators", "actuator")
    pads = _ids(model, _G, mapping.pads, "pads", "geom")
    floor = _ids(model, _G, (mapping.floor,), "floor", "geom")[0]
    sites = {
        "marker_led": _ids(model, _S, (mapping.marker_led,), "marker_led", "site")[0],
        "ball_seat": _ids(model, _S, (mapping.ball_seat,), "ball_seat", "site")[0],
        "target_led": mujoco.mj_name2id(model, _S, "target_led"),
        "landing_led": mujoco.mj_name2id(model, _S, "landing_led"),
    }
    ball_body = _ids(model, _B, (mapping.ball,), "ball", "body")[0]
    ball_joint = next((j for j in range(model.njnt) if model.jnt_bodyid[j] == ball_body), -1)
    if ball_joint < 0 or model.jnt_type[ball_joint] != mujoco.mjtJoint.mjJNT_FREE:
        raise AppError(f"mjcf.ball {mapping.ball!r} must be a body with a free joint (the ball flies)")
    table_body = _ids(model, _B, (mapping.table,), "table", "body")[0]
    if model.body_mocapid[table_body] < 0:
        raise AppError(f"mjcf.table {mapping.table!r} must be a mocap body (the operator moves it under each target)")
    table = mujoco.mj_name2id(model, _G, table_geom)
    where = f"the lab's MJCF {mapping.file}"
    servo = servo_of(model, actuators, joints, where)
    sensors = np.array(
        [
            model.sensor_adr[mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_SENSOR, f"wiithrow_ball_contact_{i}")]
            for i in range(len(sensed))
        ],
        dtype=np.int64,
    )
    link1_body = int(model.jnt_bodyid[joints[0]])
    offset = _joint1_at_zero(model, joints, link1_body)
    torque = _torque_limits(model, actuators, joints, mapping)
    dynamics = params.ArmDynamics(
        links=tuple(mujoco.mj_id2name(model, _B, int(model.jnt_bodyid[j])) for j in joints),
        torque_limit_nm=torque,
        velocity_limit=tuple(float(v) for v in arm.velocity_limit),
        rotor_inertia=tuple(float(a) for a in model.dof_armature[model.jnt_dofadr[joints]]),
        source=where,
    )
    built = BuiltModel(
        model=model,
        joint_qpos=model.jnt_qposadr[joints].astype(np.intp),
        joint_dof=model.jnt_dofadr[joints].astype(np.intp),
        arm_actuators=actuators,
        finger_actuators=finger_actuators,
        finger_qpos=model.jnt_qposadr[fingers].astype(np.intp),
        ball_qpos=int(model.jnt_qposadr[ball_joint]),
        ball_dof=int(model.jnt_dofadr[ball_joint]),
        ball_geom=mujoco.mj_name2id(model, _G, ball_geom),
        ball_body=int(ball_body),
        pad_geoms=frozenset(int(p) for p in pads),
        surface_geoms=frozenset((int(floor), int(table))),
        table_geom=int(table),
        table_mocap=int(model.body_mocapid[table_body]),
        sites={k: int(v) for k, v in sites.items()},
        pad_sensors=sensors[:2],
        surface_sensors=sensors[2:],
        link1_body=link1_body,
        link1_offset=None if np.allclose(offset[0], np.eye(3), atol=1e-12) and not offset[1].any() else offset,
        joint_names=arm.joint_names,
        dynamics=dynamics,
        home_inertia=np.zeros(arm.nq),
        servo=servo,
        finger_open_ctrl=np.array(mapping.finger_open_ctrl),
        finger_closed_ctrl=np.array(mapping.finger_closed_ctrl),
        finger_open_qpos=np.array(mapping.finger_open_qpos),
        finger_ball_qpos=np.array(mapping.finger_ball_qpos),
        table_half=tuple(float(x) for x in model.geom_size[table]),  # type: ignore[arg-type]
        floor_z=_floor_height(model, floor),
        held_offset_m=float(min(min(model.geom_size[p][0], model.geom_size[p][2]) for p in pads)),
        operator_hold=mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_EQUALITY, "wiithrow_operator_hold"),
    )
    built.home_inertia = home_inertia(model, built.joint_qpos, built.joint_dof, arm.home)
    return built


def _floor_height(model: mujoco.MjModel, floor: int) -> float:
    """The floor's height (m): a plane's, facing up; AppError for another geom."""
    data = mujoco.MjData(model)
    mujoco.mj_kinematics(model, data)
    if model.geom_type[floor] != mujoco.mjtGeom.mjGEOM_PLANE or data.geom_xmat[floor][8] < 1.0 - 1e-9:
        raise AppError("mjcf.floor must be a plane facing up (z) in the MJCF's world frame")
    return float(data.geom_xpos[floor][2])


def _joint1_at_zero(
    model: mujoco.MjModel, joints: NDArray[np.intp], body: int
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """(R, p) of the body joint 1 turns with every arm joint at 0; AppError unless joint 1 turns
    about the base's z axis through its origin (module docstring)."""
    data = mujoco.MjData(model)
    data.qpos[:] = model.qpos0
    data.qpos[model.jnt_qposadr[joints]] = 0.0
    mujoco.mj_kinematics(model, data)
    R, p = data.xmat[body].reshape(3, 3).copy(), data.xpos[body].copy()
    axis = R @ model.jnt_axis[joints[0]]
    anchor = data.xanchor[joints[0]]
    lean = math.acos(min(1.0, abs(float(axis[2])) / float(np.linalg.norm(axis))))
    if axis[2] < 0 or lean > AXIS_TOLERANCE_RAD or math.hypot(anchor[0], anchor[1]) > ORIGIN_TOLERANCE_M:
        raise AppError(
            f"mjcf.arm_joints[0] {mujoco.mj_id2name(model, _J, int(joints[0]))!r} must turn about the base's z axis "
            f"through its origin, as the spec's joint 1 (it leans {math.degrees(lean):.1f} deg, its axis passes "
            f"{1e3 * math.hypot(anchor[0], anchor[1]):.0f} mm from the origin): the MJCF's world frame is the arm's base"
        )
    return R, p


def _torque_limits(
    model: mujoco.MjModel, actuators: NDArray[np.intp], joints: NDArray[np.intp], mapping: MjcfSettings
) -> tuple[float, ...]:
    """Each arm actuator's force limit (N m): its forcerange, else its joint's actuator force
    range, else a motor's control range; AppError for an actuator that states none."""
    out = []
    for i, (a, j) in enumerate(zip(actuators, joints)):
        if model.actuator_forcelimited[a]:
            limit = float(np.max(np.abs(model.actuator_forcerange[a])))
        elif model.jnt_actfrclimited[j]:
            limit = float(np.max(np.abs(model.jnt_actfrcrange[j])))
        elif model.actuator_biastype[a] == mujoco.mjtBias.mjBIAS_NONE and model.actuator_ctrllimited[a]:
            limit = float(np.max(np.abs(model.actuator_ctrlrange[a])))
        else:
            raise AppError(
                f"mjcf.arm_actuators[{i}] {mapping.arm_actuators[i]!r} states no torque limit (forcerange): a servo "
                "without one is not an arm's"
            )
        out.append(limit)
    return tuple(out)
