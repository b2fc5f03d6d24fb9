"""Robot arms through Pinocchio: the PA-10 URDF, other arms from example-robot-data, the arm
interface and the simulated arm. Depends only on numpy, pinocchio, example-robot-data's files and
ruckig (never on vision, throwing, app or web).

    arm = load_arm("pa10")                       # or "panda", "ur5e", "ur5", or an ArmSpec; ball_offset=...
    p = arm.frame_position(arm.home, "ball")     # (3,) m, in base
    p_link1 = arm.to_frame(p, arm.home, "link1")  # R_1^T (p - o_1); arm.from_frame(...) is its inverse
    q = solve_position(arm, "marker", p_target, arm.home, face_direction=to_cameras)
    sim = SimulatedArm(arm, clock)               # implements Arm
    sim.command_position(q); sim.wait_until_idle(5.0)

Frames (every arm): `base` (root, z up; all positions are in it), `link1` (base turned by q1
about z through the base origin: the stereo rig's mount and the throw plane's frame; its plane
y = 0 holds the PA-10's arm when S3 = E2 = 0; `ArmModel.to_frame`/`from_frame` convert points),
`flange` (z out of the hand), `marker` and `ball` (0.10 m and 0.15 m beyond the flange along its z
by default). PA-10 joints: S1 S2 S3 E1 E2 W1 W2; positive S2 leans the arm forward (+x of link1).

Modules: `errors` (exceptions), `limits` (JointLimits, HasJointLimits), `model` (ArmModel:
kinematics and the base <-> frame transforms), `spec` (ArmSpec: an arm as data, the shipped specs in
robot/specs/), `arms` (the catalogue, limit defaults and load_arm), `ik`
(inverse kinematics), `trajectory` (JointTrajectory and Ruckig planning), `interface` (the Arm
protocol, JointState, Clock), `simulated` (SimulatedArm), `parked` (ParkedArm: no driver, does not
move).
"""

from wiithrow.robot.arms import DEFAULT_FRAME_OFFSETS, known_arms, load_arm, spec_of, urdf_path
from wiithrow.robot.errors import LimitError, RobotError, StartMismatchError, UnreachableError
from wiithrow.robot.ik import solve_position
from wiithrow.robot.interface import Arm, Clock, JointState
from wiithrow.robot.limits import HasJointLimits, JointLimits
from wiithrow.robot.model import NAMED_FRAMES, ArmModel
from wiithrow.robot.parked import ParkedArm
from wiithrow.robot.simulated import SimulatedArm
from wiithrow.robot.spec import ArmSpec, ThrowingSpec
from wiithrow.robot.trajectory import JointTrajectory, check_trajectory, plan_move, plan_stop

__all__ = [
    "DEFAULT_FRAME_OFFSETS",
    "NAMED_FRAMES",
    "Arm",
    "ArmModel",
    "ArmSpec",
    "Clock",
    "HasJointLimits",
    "JointLimits",
    "JointState",
    "JointTrajectory",
    "LimitError",
    "ParkedArm",
    "RobotError",
    "SimulatedArm",
    "StartMismatchError",
    "ThrowingSpec",
    "UnreachableError",
    "check_trajectory",
    "known_arms",
    "load_arm",
    "plan_move",
    "plan_stop",
    "solve_position",
    "spec_of",
    "urdf_path",
]
