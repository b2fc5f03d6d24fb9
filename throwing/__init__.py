"""Throwing: ballistics, the release model, the trained-throw library, generalization to new
targets, Ruckig limiting and the independent limit validator. Imports only `robot`, numpy, scipy
and ruckig (never vision, app or web).

A throw is planned in the throw plane: the plane y = 0 of `link1` (joint 1 turned towards the
target), (x, z) = (distance from the joint-1 axis, height), m.

    arm = robot.load_arm("pa10")
    execute = SimulatedExecution(arm, np.random.default_rng(1))        # the app injects its own
    library = simulate_training(arm, None, execute, np.random.default_rng(0))  # 25 throws
    planner = ThrowPlanner(arm, library)
    throw = planner.plan((1.3, 0.2), q1=0.4)       # a ValidatedThrow, or a clear ThrowingError
    throw.trajectory                               # robot.JointTrajectory, 1 ms, starts at rest at the wind-up pose
    throw.release_time, throw.release              # release time (s) and state (joints; ball in base)
    throw.predicted.xz                             # noise-free landing (x, z) in link1
    leave_one_out_error(library, arm)              # the model mismatch: predicted throws flown by the model vs labels
    regression_leave_one_out_error(library, arm)   # the regression's own held-out error

Modules (one job each): `errors`, `throw_plane` (the throw plane's points; link1 <-> base is
`robot.ArmModel.to_frame`/`from_frame`), `ballistics` (flight, landing, inverse ballistics), `release`
(release state, execution noise), `representation` (what a throw is: ThrowParameters, ThrowShape),
`arm_throwing` (how a given arm throws: its shape, operator pose and training area from its spec),
`forward` (parameters -> landing), `operator` (the simulated operator's search for a throw),
`library` (the trained library, simulated training), `gp` (Gaussian process regression),
`generalize` (target -> parameters, the trained area, leave-one-out), `limiting` (Ruckig limiting:
parameters -> ThrowPlan, the sampled joint trajectory, not yet validated), `validator` (independent
checks; the only way to a ValidatedThrow), `planner` (target -> ValidatedThrow: generalize, limit,
validate), `simulate` (a stand-in execution with noise and measurement).
"""

from wiithrow.throwing.arm_throwing import Area, shape_for, training_area
from wiithrow.throwing.ballistics import (
    Ball,
    Landing,
    flight_path,
    fly,
    fly_planar,
    landing_no_drag,
    min_speed_to_hit,
    speed_to_hit,
)
from wiithrow.throwing.errors import (
    InfeasibleThrowError,
    LibraryFormatError,
    NoLandingError,
    OutsideTrainedAreaError,
    ThrowingError,
    TrajectoryRejected,
    UnreachableTargetError,
)
from wiithrow.throwing.forward import PredictedLanding, predict_landing, release_of
from wiithrow.throwing.generalize import (
    Generalizer,
    LeaveOneOutResult,
    TrainedArea,
    leave_one_out_error,
    regression_leave_one_out_error,
)
from wiithrow.throwing.library import (
    TRAINING_AREA,
    ThrowLibrary,
    TrainedThrow,
    simulate_training,
    training_targets,
)
from wiithrow.throwing.limiting import ThrowPlan, plan_throw
from wiithrow.throwing.operator import OperatorSettings, solve_throw
from wiithrow.throwing.planner import AnalyticPlanner, ThrowPlanner
from wiithrow.throwing.release import ExecutionNoise, ReleaseState, noisy_release, release_state
from wiithrow.throwing.representation import ThrowParameters, ThrowShape
from wiithrow.throwing.simulate import SimulatedExecution, ThrowOutcome, simulated_library
from wiithrow.throwing.validator import Tolerances, ValidatedThrow, ValidationReport, Violation, require_valid, validate

__all__ = [
    "TRAINING_AREA",
    "AnalyticPlanner",
    "Area",
    "Ball",
    "ExecutionNoise",
    "Generalizer",
    "InfeasibleThrowError",
    "Landing",
    "LeaveOneOutResult",
    "LibraryFormatError",
    "NoLandingError",
    "OperatorSettings",
    "OutsideTrainedAreaError",
    "PredictedLanding",
    "ReleaseState",
    "SimulatedExecution",
    "ThrowLibrary",
    "ThrowOutcome",
    "ThrowParameters",
    "ThrowPlan",
    "ThrowPlanner",
    "ThrowShape",
    "ThrowingError",
    "Tolerances",
    "TrainedArea",
    "TrainedThrow",
    "TrajectoryRejected",
    "UnreachableTargetError",
    "ValidatedThrow",
    "ValidationReport",
    "Violation",
    "flight_path",
    "fly",
    "fly_planar",
    "landing_no_drag",
    "leave_one_out_error",
    "min_speed_to_hit",
    "noisy_release",
    "plan_throw",
    "predict_landing",
    "regression_leave_one_out_error",
    "release_of",
    "release_state",
    "require_valid",
    "shape_for",
    "simulate_training",
    "simulated_library",
    "solve_throw",
    "speed_to_hit",
    "training_area",
    "training_targets",
    "validate",
]
