"""The noise-free forward model of a throw: parameters -> release state -> landing.

    theta -> (q_r, dq_r) of all joints (joint 1 at q1, held joints at their angles)
          -> ball position and velocity in `base` (`release.release_state`)
          -> flight down through the landing height (`ballistics.fly`)
          -> landing expressed in `link1` at joint-1 angle q1 (`robot.ArmModel.to_frame`), i.e.
             (x, y, z) with x the distance from the joint-1 axis and y ~ 0 for a planar throw.

Used by the simulated operator (to find a throw for a target), by leave-one-out evaluation and by
Ruckig limiting (the predicted landing). The release state is the exact end of the acceleration phase
(Ruckig limiting reaches it exactly), so no trajectory is needed here.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from wiithrow.robot import ArmModel
from wiithrow.throwing.ballistics import DEFAULT_STEP, Ball, Landing, fly
from wiithrow.throwing.release import ReleaseState, release_state
from wiithrow.throwing.representation import ThrowParameters, ThrowShape


@dataclass(frozen=True)
class PredictedLanding:
    """A landing in both frames: `base` (`landing`, a ballistics.Landing) and `link1` (`link1`,
    (3,) m: x distance from the joint-1 axis, y lateral, z height)."""

    landing: Landing
    link1: np.ndarray

    @property
    def xz(self) -> np.ndarray:
        """(x, z) in the throw plane (link1), m."""
        return self.link1[[0, 2]]


def release_of(arm: ArmModel, shape: ThrowShape, params: ThrowParameters, q1: float = 0.0) -> ReleaseState:
    """The release state (joint and ball, in `base`) of the throw `params` at joint-1 angle q1;
    its time is the acceleration time T (the release on the planned trajectory's time axis)."""
    q = shape.full_q(arm, params.q_release, q1)
    dq = shape.full_dq(arm, params.dq_release)
    return release_state(arm, q, dq, shape.acceleration_time)


def landing_from_release(
    arm: ArmModel,
    release: ReleaseState,
    z_land: float,
    q1: float,
    ball: Ball | None = None,
    *,
    drag: bool = True,
    step: float = DEFAULT_STEP,
) -> PredictedLanding:
    """The landing (at height z_land) of a ball released in the state `release` (in `base`), also
    in `link1` with joint 1 at q1 (the throw's commanded angle: a noisy release's own joint 1 may
    differ; link1's placement depends on joint 1 alone)."""
    landing = fly(release.position, release.velocity, z_land, ball, drag=drag, step=step)
    q = release.q.copy()
    q[0] = q1
    return PredictedLanding(landing, arm.to_frame(landing.position, q, "link1"))


def predict_landing(
    arm: ArmModel,
    shape: ThrowShape,
    params: ThrowParameters,
    z_land: float,
    q1: float = 0.0,
    ball: Ball | None = None,
    *,
    drag: bool = True,
) -> PredictedLanding:
    """Noise-free landing of the throw `params` at the height z_land (m, base = link1 height)."""
    return landing_from_release(arm, release_of(arm, shape, params, q1), z_land, q1, ball, drag=drag)
