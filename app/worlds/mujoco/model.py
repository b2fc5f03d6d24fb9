"""The MuJoCo model of the world: the settings' arm from its URDF with published or stated
dynamics and seeded manufacturing tolerances, its hand, the ball, the floor, the target's table
and the LEDs.

`build_model(settings)` loads the arm's URDF (the settings' `ArmSpec`: the PA-10's
`robot/urdf/pa10.urdf`, the Panda's from example-robot-data, the UR5e's `robot/urdf/ur5e.urdf`, or
a lab's) with MuJoCo's URDF importer (`MjSpec`) and edits the spec:

* **The arm's joints** are the `ArmModel`'s (the spec's first joints of the URDF), each turning the
  URDF link it moves; the URDF's own hand (bodies below the flange, the Panda's fingers) and its
  mesh geoms are removed (the world's hand replaces the one, nothing draws or collides with the
  other).
* **Dynamics** (`wiithrow.app.worlds.mujoco.params`, sources there; `arm_dynamics`): the PA-10's
  published link masses and centres of mass with inertia tensors about them; any other arm's URDF
  inertials as they are (an arm whose URDF lacks an inertial or an effort limit is refused in
  one line, `check_arm`). Then the rotor inertia reflected to each joint (`armature`), viscous
  (`damping`) and Coulomb (`frictionloss`) joint friction; one torque actuator per joint, limited
  at the joint's torque limit (what the servo amplifier of `servo.py` drives), or with
  `mujoco.arm_servo` "pd_position" a joint PD on setpoints (`arm_servo.make_pd_actuator`).
* **link1**, where the rig is mounted: the body joint 1 turns, taken back by its nominal pose at
  q = 0 (`BuiltModel.link1_offset`; the identity for the PA-10, whose `link1` is that frame).
* **Tolerances** (settings `mujoco.link_length_sigma_m`, `joint_offset_sigma_rad`, seed
  `mujoco.seed`): each joint origin is moved by N(0, sigma_l^2) per coordinate, and each link's frame
  turned about its joint axis by d ~ N(0, sigma_q^2): the encoder reads q while the link stands at
  q + d. The hand's LED and the ball's seat are moved by N(0, sigma_l^2) too. The nominal URDF,
  which Pinocchio and therefore the planner and the calibration's ground truth use, knows none of
  it (`BuiltModel.tolerances` keeps them, for tests and the docs).
* **The hand**: a palm on the flange and two fingers on slide joints along the flange's y axis
  (turned about the flange's z so that they close across the throw plane: `hand_turn`; the PA-10's
  flange y already lies so, the Panda's is turned by its joint 7's pi/4),
  whose pads (boxes, friction 1) meet the ball at the `ball` frame (`ball.offset_m` beyond the
  flange); a position actuator per finger, its force limited to `mujoco.grip_force_n`, closes them
  on the ball (the target lies inside it, so they squeeze with the limited force).
* **The ball** (settings `ball`): a free sphere of the planner's radius and mass, a hollow shell's
  inertia (2/3 m r^2), under MuJoCo's ellipsoid fluid model (`fluidshape="ellipsoid"`) with the
  air density of the settings: quadratic drag rho C_blunt pi r^2 |v| v with C_blunt = Cd / 2 (so
  that it equals the planner's 1/2 rho Cd A |v| v at no spin), Stokes drag, angular drag, and lift
  from spin (Magnus, C_M = 1, and the added-mass term: net 1/2 rho V w x v for a sphere). What the
  planner lacks is the spin, the lift, the contact release and the touchdown on the ball's surface.
* **Contact**: the ball bounces on the floor (z = 0) and on a table (a box whose top is the
  target's surface, moved under the target); the contact's damping ratio gives a restitution of
  about 0.75. Arm links do not collide with anything (the planners keep them off the floor).
* **LEDs** as sites: `marker_led` in the hand (the calibration LED), `target_led` and
  `landing_led` in the world (moved by the world); the simulated Wiimotes look at their positions.
* **Contact sensors** (`ball_pad_left`, `ball_pad_right`, `ball_floor`, `ball_table`): how many
  contacts the ball has with each pad and surface, so that the compiled servo cycle (`cycle`) can
  stop at the release and the touchdown without Python looking at every step. Sensors read the
  state; they change nothing in the dynamics.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import mujoco
import numpy as np
from numpy.typing import NDArray

from wiithrow.app.errors import AppError
from wiithrow.app.settings import Settings
from wiithrow.app.worlds.mujoco import params
from wiithrow.app.worlds.mujoco.arm_servo import ServoGains, home_inertia, make_pd_actuator, tune_pd
from wiithrow.robot import ArmModel, RobotError
from wiithrow.throwing.arm_throwing import shape_for

#: Collision groups (contype, conaffinity): the ball collides with everything that has contype 1.
BALL_COLLISION = (1, 1)
SURFACE_COLLISION = (1, 0)
NO_COLLISION = (0, 0)
#: Size of the target's table top (half extents, m) and its depth below the top.
TABLE_HALF = (0.3, 0.3, 0.5)


@dataclass
class BuiltModel:
    """The compiled model and what the world needs to find in it."""

    model: mujoco.MjModel
    joint_qpos: NDArray[np.intp]  # qpos address of each arm joint
    joint_dof: NDArray[np.intp]
    arm_actuators: NDArray[np.intp]
    finger_actuators: NDArray[np.intp]
    finger_qpos: NDArray[np.intp]
    ball_qpos: int  # address of the ball's free joint (pos 3, quat 4)
    ball_dof: int
    ball_geom: int
    ball_body: int
    pad_geoms: frozenset[int]
    surface_geoms: frozenset[int]  # floor and table
    table_geom: int
    table_mocap: int
    sites: dict[str, int]  # marker_led, ball_seat, target_led, landing_led
    pad_sensors: NDArray[np.int64]  # sensordata address of the ball's contact count with each pad
    surface_sensors: NDArray[np.int64]  # ... with the floor and the table
    link1_body: int
    #: (R0, p0): the nominal pose at q = 0 of the body joint 1 turns, or None when it is the identity
    #: (the PA-10's, the UR5e's); link1 = that body's pose (R, o) times its inverse (`link1_pose`)
    link1_offset: tuple[NDArray[np.float64], NDArray[np.float64]] | None
    joint_names: tuple[str, ...]
    dynamics: params.ArmDynamics
    home_inertia: NDArray[np.float64]  # each joint's inertia at the home pose, rotor included (kg m^2)
    tolerances: dict[str, NDArray[np.float64]] = field(default_factory=dict)
    servo: ServoGains | None = None  # what the arm's actuators take (None: the project's torque motors)
    # the hand, per finger: the actuators' ctrl to open and to close (inside the ball: the force
    # limit sets the grip), the joints' position fully open and with the pad on the ball (m or rad)
    finger_open_ctrl: NDArray[np.float64] = field(default_factory=lambda: np.full(2, params.FINGER_STROKE_M))
    finger_closed_ctrl: NDArray[np.float64] = field(default_factory=lambda: np.full(2, -0.01))
    finger_open_qpos: NDArray[np.float64] = field(default_factory=lambda: np.full(2, params.FINGER_STROKE_M))
    finger_ball_qpos: NDArray[np.float64] = field(default_factory=lambda: np.zeros(2))
    table_half: tuple[float, float, float] = TABLE_HALF  # the operator's table (m, half extents)
    floor_z: float = 0.0  # the floor's height (m, base): a target there needs no table
    # the ball is between the pads while its centre is within this (m) of the seat, in any direction:
    # the pads' half-extent; a 1 N grip lets it shift 8 mm in the PA-10's wind-up
    held_offset_m: float = min(params.PAD_HALF_M[0], params.PAD_HALF_M[2])
    operator_hold: int = -1  # the equality that holds a ball on the seat until the pads touch it (-1: none)
    arm_qpos: slice = field(init=False)
    arm_dof: slice = field(init=False)
    arm_ctrl: slice = field(init=False)

    def __post_init__(self) -> None:
        if self.servo is None:
            n = self.joint_qpos.size
            self.servo = ServoGains("torque", np.zeros(n), np.zeros(n))
        # the arm's joints and motors come first in the model: slices are cheaper than index arrays
        # in the 1 kHz loop
        for name, index in (
            ("arm_qpos", self.joint_qpos),
            ("arm_dof", self.joint_dof),
            ("arm_ctrl", self.arm_actuators),
        ):
            if not np.array_equal(index, np.arange(index[0], index[0] + index.size)):
                raise ValueError(f"the arm's {name} are not contiguous in the MuJoCo model")
            setattr(self, name, slice(int(index[0]), int(index[0]) + index.size))


def _axis_quat(axis: NDArray[np.float64], angle: float) -> NDArray[np.float64]:
    h = 0.5 * angle
    return np.r_[math.cos(h), math.sin(h) * np.asarray(axis, float)]


def _quat_mul(a: NDArray[np.float64], b: NDArray[np.float64]) -> NDArray[np.float64]:
    out = np.empty(4)
    mujoco.mju_mulQuat(out, np.asarray(a, float), np.asarray(b, float))
    return out


#: The arm whose dynamics are the published figures of `params.PA10` (its URDF's are approximations).
PUBLISHED_ARM = "pa10"


def arm_dynamics(arm: ArmModel, spec: mujoco.MjSpec) -> params.ArmDynamics:
    """The dynamics of `arm` in the world (module docstring); AppError, in one line, for an arm
    whose URDF lacks an inertial on a link the arm's joints turn, or an effort limit on a joint."""
    joints = arm.joint_names
    links: list[str] = []
    for name in joints:
        body = next((b for b in spec.bodies if any(j.name == name for j in b.joints)), None)
        if body is None:
            raise AppError(f"the MuJoCo world cannot find arm {arm.name!r}'s joint {name!r} in its URDF")
        links.append(body.name)
    if arm.name == PUBLISHED_ARM and tuple(links) == params.PA10.links:
        return params.PA10
    bodies = {b.name: b for b in spec.bodies}
    massless = [n for n in links if not bodies[n].mass > 0.0]
    effort = np.asarray(arm.model.effortLimit, dtype=float)[: arm.nq]
    unlimited = [n for n, e in zip(joints, effort) if not (np.isfinite(e) and e > 0.0)]
    if massless or unlimited:
        lacks = [f"no inertial for link(s) {', '.join(massless)}"] if massless else []
        lacks += [f"no effort limit for joint(s) {', '.join(unlimited)}"] if unlimited else []
        raise AppError(
            f"the MuJoCo world needs arm {arm.name!r}'s dynamics and its URDF ({arm.urdf_path}) has "
            f"{'; '.join(lacks)}: add them to the URDF, or use the kinematic world"
        )
    return params.from_urdf(links, effort.tolist(), arm.velocity_limit.tolist(), f"the URDF {arm.urdf_path}")


def check_arm(settings: Settings) -> None:
    """AppError for settings naming an arm this world has no dynamics for (before anything is built)."""
    try:
        arm = settings.load_arm()
    except RobotError as exc:
        raise AppError(str(exc)) from None
    arm_dynamics(arm, mujoco.MjSpec.from_file(str(arm.urdf_path)))


def _pose_at_zero(body: mujoco.MjsBody) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """(R, p) of `body` in the world with every joint at 0, as its URDF states (no tolerances)."""
    R, p = np.eye(3), np.zeros(3)
    chain = []
    while body.name != "world":
        chain.append(body)
        body = body.parent
    for b in reversed(chain):
        Rb = np.empty(9)
        mujoco.mju_quat2Mat(Rb, np.asarray(b.quat, float))
        p = p + R @ np.asarray(b.pos, float)
        R = R @ Rb.reshape(3, 3)
    return R, p


def _remove_urdf_hand(spec: mujoco.MjSpec, flange: mujoco.MjsBody, joints: tuple[str, ...]) -> None:
    """Delete the bodies below the flange (the URDF's own hand), any body with a joint that is not
    the arm's (locked in the kinematic model: the Panda's fingers), and every mesh (geoms and assets)."""
    for child in list(flange.bodies):
        spec.delete(child)
    while True:  # one at a time: deleting a body deletes its subtree
        foreign = [b for b in spec.bodies if b.name != "world" and any(j.name not in joints for j in b.joints)]
        if not foreign:
            break
        spec.delete(foreign[0])
    for geom in list(spec.geoms):
        if geom.type == mujoco.mjtGeom.mjGEOM_MESH:
            spec.delete(geom)
    for mesh in list(spec.meshes):
        spec.delete(mesh)


@dataclass
class EditedSpec:
    """The edited spec (module docstring), the tolerances drawn for it, the nominal arm, its
    dynamics and link1's offset (`BuiltModel.link1_offset`)."""

    spec: mujoco.MjSpec
    tolerances: dict[str, NDArray[np.float64]]
    arm: ArmModel
    dynamics: params.ArmDynamics
    link1_offset: tuple[NDArray[np.float64], NDArray[np.float64]]


def build_spec(settings: Settings) -> EditedSpec:
    """The spec of the world of `settings`, edited (module docstring)."""
    try:
        arm = settings.load_arm()
    except RobotError as exc:
        raise AppError(str(exc)) from None
    mj = settings.mujoco
    ball = settings.ball
    rng = np.random.default_rng(mj.seed)
    spec = mujoco.MjSpec.from_file(str(arm.urdf_path))
    dyn = arm_dynamics(arm, spec)
    joints = arm.joint_names
    spec.modelname = f"wiithrow_{arm.name}_world"
    spec.compiler.discardvisual = False  # the URDF's cylinders, the palm and the fingers' rods stay (drawn, massive)
    opt = spec.option
    opt.timestep = mj.timestep_s
    # semi-implicit Euler (joint damping implicit): the ball's drag is far from stiff (its time constant
    # m / (k |v|) is seconds), and it steps at less than half the cost of implicitfast
    opt.integrator = mujoco.mjtIntegrator.mjINT_EULER
    opt.density = ball.air_density
    opt.viscosity = params.AIR_KINEMATIC_VISCOSITY
    opt.cone = mujoco.mjtCone.mjCONE_ELLIPTIC
    opt.impratio = 10.0  # stiff friction: the grip does not creep
    opt.gravity = np.array([0.0, 0.0, -9.81])

    bodies = {b.name: b for b in spec.bodies}
    flange = bodies.get(arm.spec.flange) if arm.spec is not None else None
    if flange is None:
        raise AppError(f"the MuJoCo world finds no body for arm {arm.name!r}'s flange in its URDF")
    _remove_urdf_hand(spec, flange, joints)
    link1_offset = _pose_at_zero(bodies[dyn.links[0]])
    for geom in spec.geoms:  # the URDF's cylinders: drawn, never colliding
        geom.contype, geom.conaffinity = NO_COLLISION

    n = len(joints)
    offsets = np.zeros(n)
    origin_errors = np.zeros((n, 3))
    damping, friction = dyn.viscous_damping(), dyn.coulomb_friction()
    for i, (name, joint_name) in enumerate(zip(dyn.links, joints)):
        body = bodies[name]
        joint = next(j for j in body.joints if j.name == joint_name)
        origin_errors[i] = rng.normal(0.0, mj.link_length_sigma_m, 3) if i > 0 else 0.0
        offsets[i] = rng.normal(0.0, mj.joint_offset_sigma_rad)
        body.pos = np.asarray(body.pos) + origin_errors[i]
        body.quat = _quat_mul(np.asarray(body.quat), _axis_quat(np.asarray(joint.axis), offsets[i]))
        if dyn.mass_kg is not None and dyn.com_z_m is not None and dyn.cylinder_m is not None:
            mass = dyn.mass_kg[name]
            radius, length = dyn.cylinder_m[name]
            body.explicitinertial = True
            body.mass = mass
            body.ipos = np.array([0.0, 0.0, dyn.com_z_m[name]])
            body.iquat = np.array([1.0, 0.0, 0.0, 0.0])
            body.fullinertia = np.full(6, np.nan)  # the URDF gave a full tensor; ours is diagonal
            body.inertia = np.array(params.cylinder_inertia(mass, radius, length))
        joint.armature = dyn.rotor_inertia[i]
        joint.damping = np.array([damping[i], 0.0, 0.0])
        joint.frictionloss = friction[i]
        joint.actfrclimited = mujoco.mjtLimited.mjLIMITED_FALSE
        act = spec.add_actuator(name=f"motor_{joint_name}", target=joint_name)
        act.trntype = mujoco.mjtTrn.mjTRN_JOINT
        if mj.arm_servo == "pd_position":  # a joint PD on setpoints (`arm_servo`), gains set once compiled
            make_pd_actuator(act, float(arm.lower[i]), float(arm.upper[i]), dyn.torque_limit_nm[i])
            continue
        act.set_to_motor()
        act.ctrllimited = mujoco.mjtLimited.mjLIMITED_TRUE
        act.ctrlrange = np.array([-dyn.torque_limit_nm[i], dyn.torque_limit_nm[i]])

    hand_errors = rng.normal(0.0, mj.link_length_sigma_m, (2, 3))
    _add_hand(spec, flange, settings, hand_errors, hand_turn(arm))
    _add_ball_and_scene(spec, settings)
    _add_contact_sensors(spec)
    tolerances = {"joint_offset_rad": offsets, "joint_origin_m": origin_errors, "hand_sites_m": hand_errors}
    return EditedSpec(spec, tolerances, arm, dyn, link1_offset)


def hand_turn(arm: ArmModel) -> float:
    """The angle (rad, in (-pi/2, pi/2]) about the flange's z by which the hand is turned so that
    its fingers close along the throw plane's normal (link1's y): the pads then stay beside the
    ball's path when they open (closing in the plane, the trailing pad would push it). 0 for an
    arm that does not throw. At the spec's nominal release pose; the pitch joints turn the flange
    about that normal only, so it is the same all through a throw. With n = R_flange^T y_link1,
    the flange's y turned by a about z is (-sin a, cos a, 0) = (n_x, n_y) / |(n_x, n_y)|."""
    if arm.spec is None or arm.spec.throwing is None:
        return 0.0
    q = shape_for(arm).full_q(arm, np.asarray(arm.spec.throwing.nominal_release, dtype=float), 0.0)
    n = arm.frame_placement(q, "flange")[:3, :3].T @ arm.frame_placement(q, "link1")[:3, 1]
    a = math.atan2(-n[0], n[1])
    if a > math.pi / 2:  # the hand is symmetric: a and a - pi close alike
        a -= math.pi
    elif a <= -math.pi / 2:
        a += math.pi
    return 0.0 if abs(a) < 1e-9 else a


def _add_hand(
    spec: mujoco.MjSpec, flange: mujoco.MjsBody, settings: Settings, errors: NDArray[np.float64], turn: float
) -> None:
    mj, ball = settings.mujoco, settings.ball
    if turn != 0.0:  # the hand turned about the flange's z (`hand_turn`)
        flange = flange.add_body(name="hand", quat=_axis_quat(np.array([0.0, 0.0, 1.0]), turn))
    r, z = ball.radius_m, ball.offset_m
    palm = flange.add_body(name="palm").add_geom(
        name="palm", type=mujoco.mjtGeom.mjGEOM_BOX, size=[0.03, 0.06, 0.015], pos=[0, 0, 0.015]
    )
    palm.mass = params.PALM_MASS_KG
    palm.contype, palm.conaffinity = NO_COLLISION
    palm.rgba = np.array([0.3, 0.3, 0.32, 1.0])
    flange.add_site(name="marker_led", pos=np.array([0.0, 0.0, settings.marker_offset_m]) + errors[0], size=[0.006])
    flange.add_site(name="ball_seat", pos=np.array([0.0, 0.0, z]) + errors[1], size=[0.004])
    hx, hy, hz = params.PAD_HALF_M
    for side, sign in (("left", 1.0), ("right", -1.0)):
        finger = flange.add_body(name=f"finger_{side}", pos=[0.0, sign * (r + hy), 0.0])
        joint = finger.add_joint(name=f"finger_{side}", type=mujoco.mjtJoint.mjJNT_SLIDE, axis=[0.0, sign, 0.0])
        joint.range = np.array([-0.01, params.FINGER_STROKE_M])
        joint.damping = np.array([2.0, 0.0, 0.0])
        rod = finger.add_geom(
            type=mujoco.mjtGeom.mjGEOM_BOX, size=[0.006, 0.004, 0.5 * (z - 0.03)], pos=[0, sign * hy, 0.5 * (z + 0.03)]
        )
        rod.mass = 0.5 * params.FINGER_MASS_KG
        rod.contype, rod.conaffinity = NO_COLLISION
        pad = finger.add_geom(name=f"pad_{side}", type=mujoco.mjtGeom.mjGEOM_BOX, size=[hx, hy, hz], pos=[0, 0, z])
        pad.mass = 0.5 * params.FINGER_MASS_KG
        pad.contype, pad.conaffinity = SURFACE_COLLISION
        pad.condim = 4  # torsional friction: the pads stop the ball turning about their normal too
        pad.friction = np.array([params.PAD_FRICTION, 0.01, 0.0001])
        pad.priority = 1  # the pad's contact parameters win over the ball's bouncy ones
        pad.solref = np.array([0.004, 1.0])
        pad.rgba = np.array([0.1, 0.1, 0.1, 1.0])
        act = spec.add_actuator(name=f"finger_{side}", target=f"finger_{side}")
        act.trntype = mujoco.mjtTrn.mjTRN_JOINT
        kp = mj.grip_force_n / 0.004  # the full force 4 mm short of the target
        act.set_to_position(kp=kp, kv=2.0 * math.sqrt(kp * params.FINGER_MASS_KG))
        act.forcelimited = mujoco.mjtLimited.mjLIMITED_TRUE
        act.forcerange = np.array([-mj.grip_force_n, mj.grip_force_n])
        act.ctrllimited = mujoco.mjtLimited.mjLIMITED_TRUE
        act.ctrlrange = np.array([-0.01, params.FINGER_STROKE_M])


def link1_pose(built: BuiltModel, data: mujoco.MjData) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """(R, o) of the true link1 in `data`: the body joint 1 turns (R_b, o_b), taken back by its
    nominal pose at q = 0 (R0, p0): R = R_b R0^T, o = o_b - R p0 (`BuiltModel.link1_offset`)."""
    i = built.link1_body
    R, o = data.xmat[i].reshape(3, 3), data.xpos[i]
    if built.link1_offset is None:
        return R.copy(), o.copy()
    R0, p0 = built.link1_offset
    R = R @ R0.T
    return R, o - R @ p0


def bounce_solref(timeconst: float) -> NDArray[np.float64]:
    """MuJoCo's (timeconst, damping ratio) for the restitution e of `params.BALL_RESTITUTION`: a
    contact is a damped spring, e = exp(-zeta pi / sqrt(1 - zeta^2)), so zeta = -ln e / sqrt(pi^2 + ln^2 e)."""
    ln_e = math.log(params.BALL_RESTITUTION)
    return np.array([timeconst, -ln_e / math.sqrt(math.pi**2 + ln_e**2)])


def _add_ball_and_scene(spec: mujoco.MjSpec, settings: Settings) -> None:
    ball = settings.ball
    world = spec.worldbody
    bounce = bounce_solref(
        0.02
    )  # 20 ms: shorter contacts gain energy at a 1 ms step (measured: a 1 m drop came back 3 m)
    floor = world.add_geom(name="floor", type=mujoco.mjtGeom.mjGEOM_PLANE, size=[5.0, 5.0, 0.1])
    # a mocap body: static geoms are in the world's precomputed bounding volumes, a moved one would be missed
    table_body = world.add_body(name="table", mocap=True, pos=[3.0, 3.0, -TABLE_HALF[2]])
    table = table_body.add_geom(name="table", type=mujoco.mjtGeom.mjGEOM_BOX, size=list(TABLE_HALF))
    for surface in (floor, table):
        surface.contype, surface.conaffinity = SURFACE_COLLISION
        surface.friction = np.array([0.6, 0.005, 0.0001])
        surface.solref = bounce
    table.rgba = np.array([0.55, 0.42, 0.3, 1.0])
    floor.rgba = np.array([0.8, 0.8, 0.8, 1.0])
    world.add_site(name="target_led", pos=[3.0, 3.0, 0.0], size=[0.01])
    world.add_site(name="landing_led", pos=[3.0, -3.0, 0.0], size=[0.01])

    body = world.add_body(name="ball", pos=[0.0, 0.0, 0.0])
    body.add_freejoint(name="ball")
    r, m = ball.radius_m, ball.mass_kg
    body.explicitinertial = True
    body.mass = m
    body.inertia = np.full(3, params.SHELL_INERTIA_FACTOR * m * r * r)
    geom = body.add_geom(name="ball", type=mujoco.mjtGeom.mjGEOM_SPHERE, size=[r, 0, 0])
    geom.contype, geom.conaffinity = BALL_COLLISION
    geom.condim = 6  # sliding, torsional and rolling friction on the pads and the floor
    geom.friction = np.array([params.PAD_FRICTION, 0.01, 0.0001])
    geom.solref = bounce
    geom.rgba = np.array([0.85, 0.95, 0.2, 1.0])
    geom.fluid_ellipsoid = 1.0
    # blunt drag C_D/2 (module docstring), slender and angular drag, Kutta and Magnus lift: MuJoCo's defaults
    geom.fluid_coefs = np.array([0.5 * ball.drag_coefficient, 0.25, 1.5, 1.0, 1.0])


#: The geoms whose contacts with the ball the contact sensors count.
SENSED = ("pad_left", "pad_right", "floor", "table")


def _add_contact_sensors(spec: mujoco.MjSpec) -> None:
    """One sensor per geom of `SENSED`: the number of its contacts with the ball (MuJoCo's contact
    sensor, data "found")."""
    for other in SENSED:
        sensor = spec.add_sensor(
            name=f"ball_{other}",
            type=mujoco.mjtSensor.mjSENS_CONTACT,
            objtype=mujoco.mjtObj.mjOBJ_GEOM,
            objname="ball",
            reftype=mujoco.mjtObj.mjOBJ_GEOM,
            refname=other,
        )
        sensor.intprm[0] = 1 << int(mujoco.mjtConDataField.mjCONDATA_FOUND)  # what it reports
        sensor.intprm[1] = 0  # no reduction
        sensor.intprm[2] = 1  # one slot


def build_model(settings: Settings) -> BuiltModel:
    """Compile the world of `settings` (module docstring)."""
    edited = build_spec(settings)
    arm, dyn, link1_offset, tolerances = edited.arm, edited.dynamics, edited.link1_offset, edited.tolerances
    model = edited.spec.compile()
    name = mujoco.mj_name2id

    def ids(kind: mujoco.mjtObj, names: tuple[str, ...]) -> NDArray[np.intp]:
        return np.array([name(model, kind, n) for n in names], dtype=np.intp)

    joints = ids(mujoco.mjtObj.mjOBJ_JOINT, arm.joint_names)
    fingers = ids(mujoco.mjtObj.mjOBJ_JOINT, ("finger_left", "finger_right"))
    ball_joint = name(model, mujoco.mjtObj.mjOBJ_JOINT, "ball")
    geom = {n: name(model, mujoco.mjtObj.mjOBJ_GEOM, n) for n in ("ball", "pad_left", "pad_right", "floor", "table")}
    sensors = model.sensor_adr[ids(mujoco.mjtObj.mjOBJ_SENSOR, tuple(f"ball_{g}" for g in SENSED))].astype(np.int64)
    built = BuiltModel(
        model=model,
        joint_qpos=model.jnt_qposadr[joints].astype(np.intp),
        joint_dof=model.jnt_dofadr[joints].astype(np.intp),
        arm_actuators=ids(mujoco.mjtObj.mjOBJ_ACTUATOR, tuple(f"motor_{j}" for j in arm.joint_names)),
        finger_actuators=ids(mujoco.mjtObj.mjOBJ_ACTUATOR, ("finger_left", "finger_right")),
        finger_qpos=model.jnt_qposadr[fingers].astype(np.intp),
        ball_qpos=int(model.jnt_qposadr[ball_joint]),
        ball_dof=int(model.jnt_dofadr[ball_joint]),
        ball_geom=geom["ball"],
        ball_body=name(model, mujoco.mjtObj.mjOBJ_BODY, "ball"),
        pad_geoms=frozenset((geom["pad_left"], geom["pad_right"])),
        surface_geoms=frozenset((geom["floor"], geom["table"])),
        table_geom=geom["table"],
        table_mocap=int(model.body_mocapid[name(model, mujoco.mjtObj.mjOBJ_BODY, "table")]),
        sites={
            n: name(model, mujoco.mjtObj.mjOBJ_SITE, n)
            for n in ("marker_led", "ball_seat", "target_led", "landing_led")
        },
        pad_sensors=sensors[:2],
        surface_sensors=sensors[2:],
        link1_body=name(model, mujoco.mjtObj.mjOBJ_BODY, dyn.links[0]),
        link1_offset=None if np.array_equal(link1_offset[0], np.eye(3)) and not link1_offset[1].any() else link1_offset,
        joint_names=arm.joint_names,
        dynamics=dyn,
        home_inertia=np.zeros(arm.nq),
        tolerances=tolerances,
    )
    if settings.mujoco.arm_servo == "pd_position":
        mj = settings.mujoco
        built.servo = tune_pd(
            model,
            built.arm_actuators,
            home_inertia(model, built.joint_qpos, built.joint_dof, arm.home),
            mj.pd_bandwidth_hz,
            mj.pd_lag_s,
        )
    return built
