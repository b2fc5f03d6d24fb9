"""The release: the state the ball leaves the hand with, and the execution noise around it.

At the release time t_r the gripper lets go and the ball takes over the `ball` frame's state:

    p_ball = FK_ball(q(t_r))                  (3,) in `base`
    v_ball = J_ball,lin(q(t_r)) dq(t_r)        (3,) in `base` (the frame Jacobian's linear rows)

The ball then flies (`wiithrow.throwing.ballistics`). `ReleaseState` holds both the joint state and the
ball's state.

Execution noise (`ExecutionNoise`, all settings, all drawn from an explicit Generator):
- release-time jitter: the gripper opens at t_r + dt, dt ~ N(0, release_jitter_s^2) (default
  2 ms), so the ball takes the trajectory's state at that time;
- joint tracking error: each joint's actual angle is q + e, e ~ N(0, tracking_error_rad^2)
  (default 1 mrad, independent per joint), as `robot.SimulatedArm`'s `tracking_error_rad` (whose
  velocities carry no error either; its error is an AR(1) process in time, here one draw per
  release, which is what matters at one instant).
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from wiithrow.robot import ArmModel, JointTrajectory
from wiithrow.throwing.errors import ThrowingError


@dataclass(frozen=True)
class ReleaseState:
    """The release: `time` (s, on the trajectory's time axis), joint state `q`, `dq` (nq,) in rad
    and rad/s, and the ball's `position` (3,) m and `velocity` (3,) m/s in `base`."""

    time: float
    q: NDArray[np.float64]
    dq: NDArray[np.float64]
    position: NDArray[np.float64]
    velocity: NDArray[np.float64]


def release_state(arm: ArmModel, q: ArrayLike, dq: ArrayLike, time: float = 0.0) -> ReleaseState:
    """The ball's release state in `base` for the joint state (q, dq): the `ball` frame's position
    and its velocity J_lin(q) dq (one kinematics pass)."""
    qv = np.array(q, dtype=np.float64)
    dqv = np.array(dq, dtype=np.float64)
    T, J = arm.frame_placement_and_jacobian(qv, "ball")
    if dqv.shape != (arm.nq,) or not np.all(np.isfinite(dqv)):
        raise ThrowingError(f"dq must be a finite ({arm.nq},) vector, got shape {dqv.shape}")
    return ReleaseState(float(time), qv, dqv, T[:3, 3].copy(), J[:3] @ dqv)


@dataclass(frozen=True)
class ExecutionNoise:
    """Execution noise of a throw (module docstring): release-time jitter (s) and joint tracking
    error (rad), both standard deviations."""

    release_jitter_s: float = 0.002
    tracking_error_rad: float = 0.001

    def __post_init__(self) -> None:
        for name in ("release_jitter_s", "tracking_error_rad"):
            v = getattr(self, name)
            if not (math.isfinite(v) and v >= 0):
                raise ThrowingError(f"ExecutionNoise.{name} must be >= 0, got {v}")

    @classmethod
    def none(cls) -> ExecutionNoise:
        """No noise at all."""
        return cls(0.0, 0.0)

    def to_dict(self) -> dict[str, float]:
        return asdict(self)


def noisy_release(
    arm: ArmModel,
    trajectory: JointTrajectory,
    release_time: float,
    noise: ExecutionNoise,
    rng: np.random.Generator,
) -> ReleaseState:
    """The release state of one noisy execution of `trajectory` (released at `release_time`):
    the trajectory's state at t_r + dt (dt ~ N(0, jitter^2), interpolated by
    `JointTrajectory.sample`), joint angles plus N(0, tracking^2) each, then `release_state`."""
    if not isinstance(rng, np.random.Generator):
        raise ThrowingError("noisy_release needs an explicit numpy.random.Generator")
    dt = rng.normal(0.0, noise.release_jitter_s) if noise.release_jitter_s > 0 else 0.0
    t = float(release_time) + dt
    q, dq, _ = trajectory.sample(t)
    if noise.tracking_error_rad > 0:
        q = q + rng.normal(0.0, noise.tracking_error_rad, q.shape)
    return release_state(arm, q, dq, t)
