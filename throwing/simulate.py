"""A stand-in for executing and measuring a throw, for tests and offline studies.

The app's execution plays a validated throw on `robot.SimulatedArm`, flies the ball in its world
and measures the landing marker with the simulated stereo rig. This stand-in keeps only what
matters for the landing, each part a setting, all randomness from one explicit Generator:

    release  = noisy_release(trajectory, t_r)        jitter N(0, 2 ms), joint tracking N(0, 1 mrad)
    landing  = fly(release, down through the target's height, with drag)
    measured = landing (x, z) in link1 + N(0, measurement_sigma^2) per coordinate (2 mm)

It only executes `ValidatedThrow`s (nothing executes without the validator). As a callable,
`SimulatedExecution(params, target)` is the `execute_and_measure` of `library.simulate_training`:
plan, validate, execute, return the measured (x, z).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from wiithrow.robot import ArmModel
from wiithrow.throwing.arm_throwing import shape_for
from wiithrow.throwing.ballistics import Ball
from wiithrow.throwing.errors import ThrowingError
from wiithrow.throwing.forward import PredictedLanding, landing_from_release
from wiithrow.throwing.library import ThrowLibrary, simulate_training
from wiithrow.throwing.limiting import plan_throw
from wiithrow.throwing.release import ExecutionNoise, ReleaseState, noisy_release
from wiithrow.throwing.representation import ThrowParameters, ThrowShape
from wiithrow.throwing.throw_plane import xz
from wiithrow.throwing.validator import ValidatedThrow, require_valid


@dataclass(frozen=True)
class ThrowOutcome:
    """One executed throw: the actual `release` (noisy, in `base`), the true `landing` (base and
    link1) at the throw's landing height, and the `measured` landing (x, z) in link1."""

    release: ReleaseState
    landing: PredictedLanding
    measured: NDArray[np.float64]

    def error(self, target: ArrayLike) -> float:
        """Distance (m) at the target's height between the true landing and `target` (x, z) in
        link1, including the lateral (y) miss."""
        t = xz(target)
        return float(math.hypot(self.landing.link1[0] - t[0], self.landing.link1[1]))


class SimulatedExecution:
    """Executes validated throws with noise and measures their landings (module docstring).

    `q1` (rad): joint 1's angle used when called as `execute_and_measure`; `shape` (default: the
    arm's), `ball`: those of the throws; `floor_margin` (m): the validator's clearance.
    """

    def __init__(
        self,
        arm: ArmModel,
        rng: np.random.Generator,
        *,
        noise: ExecutionNoise | None = None,
        measurement_sigma: float = 0.002,
        ball: Ball | None = None,
        shape: ThrowShape | None = None,
        q1: float = 0.0,
        floor_margin: float = 0.05,
    ) -> None:
        if not isinstance(rng, np.random.Generator):
            raise ThrowingError("SimulatedExecution needs an explicit numpy.random.Generator")
        if not (math.isfinite(measurement_sigma) and measurement_sigma >= 0):
            raise ThrowingError(f"measurement_sigma must be >= 0, got {measurement_sigma}")
        self.arm = arm
        self.rng = rng
        self.noise = noise if noise is not None else ExecutionNoise()
        self.measurement_sigma = float(measurement_sigma)
        self.ball = ball or Ball()
        self.shape = shape or shape_for(arm)
        self.q1 = float(q1)
        self.floor_margin = float(floor_margin)
        self.last: ThrowOutcome | None = None

    def execute(self, throw: ValidatedThrow) -> ThrowOutcome:
        """Execute one validated throw with noise; the ball flies down through its landing height."""
        if not isinstance(throw, ValidatedThrow):
            raise ThrowingError(
                f"only a ValidatedThrow is executed, got {type(throw).__name__}; "
                "validate it with wiithrow.throwing.validator.require_valid"
            )
        release = noisy_release(self.arm, throw.trajectory, throw.release_time, self.noise, self.rng)
        landing = landing_from_release(self.arm, release, throw.landing_height, throw.q1, self.ball)
        measured = landing.xz + (self.rng.normal(0.0, self.measurement_sigma, 2) if self.measurement_sigma > 0 else 0.0)
        self.last = ThrowOutcome(release, landing, measured)
        return self.last

    def __call__(self, params: ThrowParameters, target: ArrayLike) -> NDArray[np.float64]:
        """`execute_and_measure`: plan `params` (landing at the target's height), validate, execute;
        the measured landing (x, z) in link1."""
        t = xz(target)
        plan = plan_throw(self.arm, params, float(t[1]), q1=self.q1, shape=self.shape, ball=self.ball, target=t)
        return self.execute(require_valid(plan, self.arm, floor_margin=self.floor_margin)).measured


def simulated_library(
    arm: ArmModel,
    seed: int = 0,
    *,
    targets: ArrayLike | None = None,
    noise: ExecutionNoise | None = None,
    measurement_sigma: float = 0.002,
    placement_jitter: float = 0.01,
) -> ThrowLibrary:
    """A library trained in simulation with this stand-in (5 x 5 grid over the arm's training area unless
    `targets`), reproducible from `seed`: the operator's placement from default_rng(seed), the
    execution noise from default_rng(seed + 1)."""
    execute = SimulatedExecution(arm, np.random.default_rng(seed + 1), noise=noise, measurement_sigma=measurement_sigma)
    meta = {
        "execution": "wiithrow.throwing.simulate.SimulatedExecution",
        "seed": seed,
        "noise": execute.noise.to_dict(),
        "measurement_sigma": measurement_sigma,
    }
    return simulate_training(
        arm, targets, execute, np.random.default_rng(seed), placement_jitter=placement_jitter, meta=meta
    )
