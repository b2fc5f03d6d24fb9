"""Where the hand should hold the calibration LED: reachable, visible, and spread for a small error.

Owns the choice of the robot-driven calibration's marker positions (in `link1`) and the
measurements that justify it, one module each:

1. `candidates`: reachable configurations whose LED every camera sees and which face the rig;
2. `error_model`: the design criterion, the 3D error the calibration adds at test points, from
   first-order error propagation of the DLT;
3. `design`: `select_poses`, the optimal (greedy I-optimal) or a random design, ordered for short moves;
4. `scoring`: a design measured without the robot against the true cameras;
5. `coverage`: what a rig sees of the throwing area.
"""

from wiithrow.app.calibration.poses.candidates import (
    PoseCandidates,
    PoseCheck,
    rig_center,
    sample_candidates,
)
from wiithrow.app.calibration.poses.coverage import RigCoverage, rig_coverage
from wiithrow.app.calibration.poses.design import DESIGNS, Design, PosePlan, greedy_optimal, select_poses, travel_order
from wiithrow.app.calibration.poses.error_model import ErrorModel, frame_sigma_px, parameter_jacobians, point_jacobians
from wiithrow.app.calibration.poses.scoring import DesignScore, averaged_pixels, evaluate_design, score_calibration

__all__ = [
    "DESIGNS",
    "Design",
    "DesignScore",
    "ErrorModel",
    "PoseCandidates",
    "PoseCheck",
    "PosePlan",
    "RigCoverage",
    "averaged_pixels",
    "evaluate_design",
    "frame_sigma_px",
    "greedy_optimal",
    "parameter_jacobians",
    "point_jacobians",
    "rig_center",
    "rig_coverage",
    "sample_candidates",
    "score_calibration",
    "select_poses",
    "travel_order",
]
