"""The throw planner: target -> validated, executable throw, in one call.

    target (x, z) in link1 --Generalizer--> parameters --plan_throw--> ThrowPlan
                          --validator.require_valid--> ValidatedThrow

Where a target lies in base, `aim` says where in the throw plane to plan for and joint 1's angle:
the target's azimuth turned by the learned sideways correction (`lateral`: the throws' across
offset, aimed away), so that a throw that lands beside its plane comes down on the target.

`AnalyticPlanner` plans the same way without the learning (the nominal model's exact solution,
joint 1 at the target's azimuth), as a baseline.

Raises OutsideTrainedAreaError for a target outside the trained area (unless within the allowed
margin), InfeasibleThrowError if the regressed parameters are not executable by construction, and
TrajectoryRejected if the validator finds a violation; otherwise the result may be executed.
"""

from __future__ import annotations

from typing import Protocol

import numpy as np
from numpy.typing import ArrayLike, NDArray

from wiithrow.robot import ArmModel
from wiithrow.throwing.ballistics import Ball
from wiithrow.throwing.generalize import Generalizer, TrainedArea
from wiithrow.throwing.lateral import Aim, aim_at
from wiithrow.throwing.library import ThrowLibrary
from wiithrow.throwing.limiting import plan_throw
from wiithrow.throwing.operator import solve_throw
from wiithrow.throwing.representation import ThrowParameters
from wiithrow.throwing.throw_plane import xz
from wiithrow.throwing.validator import Tolerances, ValidatedThrow, require_valid


class Regression(Protocol):
    """What the planner asks of a regression: `generalize.Generalizer`, `online.OnlineLibrary`."""

    @property
    def area(self) -> TrainedArea: ...

    def params_for(self, target: ArrayLike, margin: float = 0.0) -> ThrowParameters: ...

    def across(self, target: ArrayLike) -> float: ...


class ThrowPlanner:
    """Plans validated throws for one arm from one library.

    `margin` (m): how far outside the trained area targets are still served by default (0);
    `floor_margin` (m): the validator's clearance above z = 0 of base; `dt` (s): sample interval;
    `generalizer`: the regression to serve targets with (default: a `Generalizer` fitted to
    `library`; a learning library gives its `online.OnlineLibrary`, which keeps learning).
    """

    def __init__(
        self,
        arm: ArmModel,
        library: ThrowLibrary,
        *,
        ball: Ball | None = None,
        margin: float = 0.0,
        floor_margin: float = 0.05,
        dt: float = 0.001,
        tolerances: Tolerances | None = None,
        generalizer: Regression | None = None,
    ) -> None:
        library.require_arm(arm.name)
        self.arm = arm
        self.library = library
        self.shape = library.shape
        self.ball = ball or library.ball
        self.margin = float(margin)
        self.floor_margin = float(floor_margin)
        self.dt = float(dt)
        self.tolerances = tolerances
        self.generalizer: Regression = generalizer if generalizer is not None else Generalizer(library)

    @property
    def area(self) -> TrainedArea:
        """The trained area (`generalize.TrainedArea`)."""
        return self.generalizer.area

    def aim(self, distance: float, height: float, azimuth: float) -> Aim:
        """Where to plan for a target `distance` (m) from joint 1's axis at `height` (m) and
        `azimuth` (rad, base): the landing (x, z) in the throw plane and joint 1's angle, the
        learned across offset at the target aimed away (`lateral.aim_at`)."""
        return aim_at(self.generalizer.across((distance, height)), distance, height, azimuth)

    def plan(
        self, target: ArrayLike, q1: float = 0.0, *, margin: float | None = None, q_start: ArrayLike | None = None
    ) -> ValidatedThrow:
        """A validated throw to `target` (x, z) in link1 with joint 1 at q1 (rad); `q_start` (nq,)
        adds a prelude from that pose at rest to the wind-up pose (see `limiting.plan_throw`)."""
        t = xz(target)
        return self.validated(self.generalizer.params_for(t, self.margin if margin is None else margin), t, q1, q_start)

    def validated(
        self, params: ThrowParameters, target: NDArray[np.float64], q1: float, q_start: ArrayLike | None
    ) -> ValidatedThrow:
        """The throw `params` to `target` (x, z) planned (Ruckig limiting) and validated."""
        plan = plan_throw(
            self.arm,
            params,
            float(target[1]),
            q1=q1,
            shape=self.shape,
            ball=self.ball,
            dt=self.dt,
            q_start=q_start,
            target=target,
        )
        return require_valid(
            plan,
            self.arm,
            floor_margin=self.floor_margin,
            tolerances=self.tolerances,
            velocity_margin=self.shape.velocity_margin,
        )


class AnalyticPlanner:
    """Plans validated throws with no learning: the throw parameters for a target are the simulated
    operator's solution on the nominal model (`operator.solve_throw`: the planner's kinematics and
    ballistics, the ball's centre through the target's height), started from the library's
    regression for speed and uniqueness. What the planner would do if its model were the world; the
    benchmark's baseline for what the learning from measured landings adds.

    Same interface as `ThrowPlanner` (`plan`, `area`); targets are served within the library's
    trained area (plus `margin`), where the operator's solution exists.
    """

    def __init__(
        self,
        arm: ArmModel,
        library: ThrowLibrary,
        *,
        ball: Ball | None = None,
        margin: float = 0.0,
        floor_margin: float = 0.05,
        dt: float = 0.001,
        generalizer: Regression | None = None,
    ) -> None:
        self.learned = ThrowPlanner(
            arm, library, ball=ball, margin=margin, floor_margin=floor_margin, dt=dt, generalizer=generalizer
        )
        self.arm = arm

    @property
    def area(self) -> TrainedArea:
        return self.learned.area

    def aim(self, distance: float, height: float, azimuth: float) -> Aim:
        """Joint 1 at the target's azimuth, the target at (`distance`, `height`): no learned correction."""
        return aim_at(0.0, distance, height, azimuth)

    def plan(
        self, target: ArrayLike, q1: float = 0.0, *, margin: float | None = None, q_start: ArrayLike | None = None
    ) -> ValidatedThrow:
        """A validated throw to `target` (x, z) in link1 whose noise-free model lands exactly there."""
        learned = self.learned
        t = xz(target)
        guess = learned.generalizer.params_for(t, learned.margin if margin is None else margin)
        params = solve_throw(self.arm, t, shape=learned.shape, ball=learned.ball, initial=guess)
        return learned.validated(params, t, q1, q_start)
