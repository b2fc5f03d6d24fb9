"""The exceptions of the robot package: each says what was wrong and what to do about it.

All derive from `RobotError`, itself a `ValueError`, so a caller can catch every expected failure
of this package (bad input, unreachable target, limit violation) with one clause.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike


class RobotError(ValueError):
    """Base class of every expected failure in `robot` (unknown arm or frame, bad shapes, ...)."""


class LimitError(RobotError):
    """A joint position, velocity, acceleration or jerk is outside the arm's limits.

    `joint` names the first offending joint (None when the error is not about one joint).
    """

    def __init__(self, message: str, joint: str | None = None) -> None:
        super().__init__(message)
        self.joint = joint


class StartMismatchError(RobotError):
    """A commanded trajectory does not start where the arm is (more than the arm's tolerance away).

    `joint` names the joint with the largest gap, `gap` is that gap (rad). The arm did not move;
    re-plan from `Arm.state()` and command again.
    """

    def __init__(self, message: str, joint: str, gap: float) -> None:
        super().__init__(message)
        self.joint = joint
        self.gap = float(gap)


class UnreachableError(RobotError):
    """Inverse kinematics could not bring a frame to a target position.

    Attributes: `target` (3,) the position asked for, in `base`; `distance` the smallest distance
    (m) between the frame and the target that the solver reached; `frame` the frame's name;
    `q_best` the configuration that reached that distance.
    """

    def __init__(self, target: ArrayLike, distance: float, frame: str, q_best: ArrayLike | None = None) -> None:
        self.target = np.asarray(target, dtype=float).copy()
        self.distance = float(distance)
        self.frame = frame
        self.q_best = None if q_best is None else np.asarray(q_best, dtype=float).copy()
        t = ", ".join(f"{v:.4f}" for v in self.target)
        super().__init__(
            f"frame '{frame}' cannot reach ({t}) m in base: the closest the solver got was "
            f"{self.distance:.4f} m; move the target closer to the arm or unlock joints"
        )
