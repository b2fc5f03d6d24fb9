"""The simulated operator: finds, on the noise-free model, the throw parameters that hit a target.

In the paper a human trains each of the 25 throws by trial and error. Here that search is an
optimisation on the noise-free forward model (`wiithrow.throwing.forward`): among all throws whose ball
comes down through the target's height at the target's distance, take the one of least effort,

    minimise   J(theta) = w_v sum_j (dq_j / v_max,j)^4  +  w_q sum_j (q_j - q_nom,j)^2
    subject to x_land(theta; z_t) = x_t,    |dq_j| <= speed_cap margin v_max,j,   q within the limits

(margin: the representation's velocity margin, 95 %; speed_cap 0.9, so 85.5 % of the limits),
by SLSQP with the constraint's gradient by central differences. The 4th power spreads the effort over
the joints (a smooth stand-in for the largest relative speed), which also maximises the reach; the
small pull towards a nominal release pose q_nom makes the optimum unique. A slow throw is a robust
one: near the least-speed throw the landing is first-order insensitive to the release direction, so
release-time jitter and tracking errors move it little. The optimum is a smooth function of the
target, which is what makes the library regressable.

All targets are (x, z) in `link1` (m); the throw is solved at q1 = 0 (a throw in link1 does not
depend on joint 1's angle).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike
from scipy.optimize import minimize

from wiithrow.robot import ArmModel
from wiithrow.throwing.arm_throwing import directions, nominal_release, shape_for
from wiithrow.throwing.ballistics import Ball
from wiithrow.throwing.errors import NoLandingError, UnreachableTargetError
from wiithrow.throwing.forward import predict_landing
from wiithrow.throwing.representation import ACCEL_PEAK_FACTOR, JERK_PEAK_FACTOR, ThrowParameters, ThrowShape
from wiithrow.throwing.throw_plane import xz


@dataclass(frozen=True)
class OperatorSettings:
    """Settings of the simulated operator (module docstring). `nominal_q`: the preferred release
    pose of the moving joints (rad; None: the arm's, `arm_throwing.nominal_release`, for the PA-10
    (0.6, -0.4, -0.35)); `speed_cap`: largest |dq| / v_max it uses; `tolerance`: the
    landing miss (m) it accepts on the noise-free model."""

    nominal_q: tuple[float, ...] | None = None  # None: the arm's (its spec's `nominal_release`)
    speed_cap: float = 0.9
    speed_weight: float = 4.0
    pose_weight: float = 1.0
    tolerance: float = 1e-6
    max_iterations: int = 200


def solve_throw(
    arm: ArmModel,
    target: ArrayLike,
    *,
    shape: ThrowShape | None = None,
    ball: Ball | None = None,
    settings: OperatorSettings | None = None,
    initial: ThrowParameters | None = None,
) -> ThrowParameters:
    """Throw parameters whose noise-free ball (with drag) lands on `target` (x, z) in link1.

    Raises UnreachableTargetError if no throw within `speed_cap` of the velocity limits reaches it.
    """
    shape = shape or shape_for(arm)
    ball = ball or Ball()
    st = settings or OperatorSettings()
    xt, zt = xz(target)
    mov, _, _ = shape.joint_layout(arm)
    n = shape.n
    vmax = arm.velocity_limit[mov]
    q_nom = np.asarray(nominal_release(arm) if st.nominal_q is None else st.nominal_q, dtype=float)
    if q_nom.shape != (n,):
        raise UnreachableTargetError(f"nominal_q needs {n} values, got {q_nom.shape}")
    cap = st.speed_cap * min(1.0, shape.velocity_margin)
    T = shape.acceleration_time
    # the fastest release whose acceleration phase keeps within the acceleration and jerk limits
    # (peaks 15/8 |dq|/T and 10/sqrt(3) |dq|/T^2; never binding for the PA-10, binding for the
    # Panda's shoulder, 7.5 rad/s^2)
    dq_max = np.minimum.reduce(
        [
            cap * vmax,
            arm.acceleration_limit[mov] * T / ACCEL_PEAK_FACTOR,
            arm.jerk_limit[mov] * T**2 / JERK_PEAK_FACTOR,
        ]
    )
    # room for the wind-up (half T dq behind the release, + 0.05 rad) and the follow-through (0.6 rad
    # ahead of it), on the sides the arm's throwing directions say (PA-10: all +1)
    sign = directions(arm) if arm.spec is not None and arm.spec.throwing is not None else np.ones(n)
    behind = 0.5 * T * dq_max + 0.05
    ahead = np.full(n, 0.6)
    lo = np.r_[arm.lower[mov] + np.where(sign > 0, behind, ahead), -dq_max]
    hi = np.r_[arm.upper[mov] - np.where(sign > 0, ahead, behind), dq_max]

    def miss(theta: np.ndarray) -> float:
        try:
            land = predict_landing(arm, shape, ThrowParameters.from_vector(theta), zt, 0.0, ball)
        except NoLandingError:
            return -10.0  # short: the ball does not even reach the target's height
        return float(land.link1[0] - xt)

    def miss_grad(theta: np.ndarray) -> np.ndarray:
        g = np.empty(2 * n)
        for i in range(2 * n):
            e = np.zeros(2 * n)
            e[i] = 1e-6
            g[i] = (miss(theta + e) - miss(theta - e)) / 2e-6
        return g

    def cost(theta: np.ndarray) -> float:
        r = theta[n:] / vmax
        return float(st.speed_weight * np.sum(r**4) + st.pose_weight * np.sum((theta[:n] - q_nom) ** 2))

    def cost_grad(theta: np.ndarray) -> np.ndarray:
        r = theta[n:] / vmax
        return np.concatenate([2 * st.pose_weight * (theta[:n] - q_nom), 4 * st.speed_weight * r**3 / vmax])

    x0 = initial.vector if initial is not None else np.r_[q_nom, 0.5 * sign * dq_max]
    res = minimize(
        cost,
        np.clip(x0, lo, hi),
        jac=cost_grad,
        method="SLSQP",
        bounds=list(zip(lo, hi)),
        constraints=[{"type": "eq", "fun": miss, "jac": miss_grad}],
        options={"ftol": 1e-12, "maxiter": st.max_iterations},
    )
    m = miss(res.x)
    if not abs(m) <= st.tolerance:
        raise UnreachableTargetError(
            f"the operator found no throw landing at ({xt:.3f}, {zt:.3f}) m in link1 within "
            f"{st.speed_cap:.0%} of the velocity limits (best miss {m:+.4f} m: "
            f"{'short' if m < 0 else 'long'}); choose a target inside the throwing range"
        )
    return ThrowParameters.from_vector(res.x)


def relative_speed(arm: ArmModel, shape: ThrowShape, params: ThrowParameters) -> float:
    """max_j |dq_r,j| / v_max,j: how close a throw comes to the velocity limits."""
    mov, _, _ = shape.joint_layout(arm)
    return float(np.max(np.abs(params.dq_release) / arm.velocity_limit[mov]))
