"""The design criterion: how much 3D error a set of calibration points lets the calibration add.

The expected squared 3D error that the calibration adds at test points spread through the same
volume (I-optimality), from first-order error propagation of the DLT. Camera c has 11 parameters
theta_c (fx, fy, skew, cx, cy, rotation w, centre C); with J_ic the 2x11 Jacobian of its pixel of
calibration point i,

    Sigma_c = (sum_i J_ic^T J_ic / sigma_cal^2 + Lambda0)^-1            (the fit's covariance)

A test point X_t triangulated from pixels x_t: with A_c = d pi_c / dX (2x3) and
B_tc = d pi_c / d theta_c (2x11), the linearised least-squares point moves by
dX = -N_t^-1 sum_c A_c^T B_tc d theta_c,  N_t = sum_c A_c^T A_c, so

    E ||dX_t||^2 = sigma_test^2 tr(N_t^-1)   +   sum_c tr(G_tc Sigma_c G_tc^T),   G_tc = N_t^-1 A_c^T B_tc
                   (pixel noise: the true cameras' error)   (the calibration's share)

and a design minimises  Phi = sum_c tr(Sigma_c H_c),  H_c = sum_t G_tc^T G_tc  (`ErrorModel`).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from wiithrow.vision.camera import WiimoteCamera
from wiithrow.vision.dlt_solvers import compose_camera
from wiithrow.vision.geometry import project

#: Pixel noise of one frame: sigma before rounding plus the rounding itself (uniform, variance 1/12).
ROUNDING_VARIANCE_PX2 = 1.0 / 12.0


#: Scale of each camera parameter for the weak prior Lambda0 and the finite differences:
#: fx, fy, skew, cx, cy (px); rotation (rad); centre (m).
_PARAM_SCALE = np.array([100.0, 100.0, 100.0, 100.0, 100.0, 0.1, 0.1, 0.1, 0.1, 0.1, 0.1])
_PRIOR_SIGMA = 1e3  # the prior allows each parameter 1000 scales: weak, only keeps Sigma finite


def _camera_P(camera: WiimoteCamera, theta: NDArray[np.float64]) -> NDArray[np.float64]:
    """P = K [R | -R C] of `camera` perturbed by theta (11,): added to fx, fy, skew, cx, cy; a
    rotation exp([w]x) before R; added to the centre C."""
    K = camera.K
    params = np.concatenate(
        [
            [K[0, 0] + theta[0], K[0, 1] + theta[2], K[0, 2] + theta[3], K[1, 1] + theta[1], K[1, 2] + theta[4]],
            theta[5:8],
            camera.center + theta[8:11],
        ]
    )
    return compose_camera(params, camera.R)


def parameter_jacobians(camera: WiimoteCamera, points: ArrayLike) -> NDArray[np.float64]:
    """d pixel / d theta (N, 2, 11) of `camera`'s 11 parameters at points (N, 3), central differences."""
    X = np.asarray(points, dtype=float).reshape(-1, 3)
    J = np.empty((len(X), 2, 11))
    for k in range(11):
        h = np.zeros(11)
        h[k] = 1e-4 * _PARAM_SCALE[k]
        J[:, :, k] = (project(_camera_P(camera, h), X) - project(_camera_P(camera, -h), X)) / (2 * h[k])
    return J


def point_jacobians(camera: WiimoteCamera, points: ArrayLike) -> NDArray[np.float64]:
    """d pixel / d X (N, 2, 3): with (a, b, w) = P [X; 1], (u, v) = (a, b) / w,
    d(u, v)/dX = (P[:2, :3] - (u, v)^T P[2, :3]) / w."""
    X = np.asarray(points, dtype=float).reshape(-1, 3)
    P = camera.P
    x = X @ P[:, :3].T + P[:, 3]
    uv = x[:, :2] / x[:, 2:3]
    return (P[None, :2, :3] - uv[:, :, None] * P[None, 2:3, :3]) / x[:, 2, None, None]


@dataclass(frozen=True)
class ErrorModel:
    """First-order error propagation of a rig calibrated on chosen points (see the module docstring).

    `H` (C, 11, 11): the test points' sensitivity to each camera's parameters; `irreducible_m2`:
    mean of tr(N_t^-1) (m^2 per px^2), the true cameras' squared error per unit pixel variance.
    """

    cameras: tuple[WiimoteCamera, ...]
    test_points: NDArray[np.float64]
    H: NDArray[np.float64]
    irreducible_m2: float

    @classmethod
    def build(cls, cameras: Sequence[WiimoteCamera], test_points: ArrayLike) -> ErrorModel:
        T = np.asarray(test_points, dtype=float).reshape(-1, 3)
        A = [point_jacobians(c, T) for c in cameras]  # (T, 2, 3) each
        B = [parameter_jacobians(c, T) for c in cameras]  # (T, 2, 11) each
        N = sum(np.einsum("tki,tkj->tij", a, a) for a in A)
        N_inv = np.linalg.inv(N)
        H = []
        for a, b in zip(A, B):
            G = np.einsum("tij,tkj,tkl->til", N_inv, a, b)  # N^-1 A_c^T B_c: (T, 3, 11)
            H.append(np.einsum("tia,tib->ab", G, G) / len(T))
        irreducible = float(np.mean(np.trace(N_inv, axis1=1, axis2=2)))
        return cls(tuple(cameras), T, np.array(H), irreducible)

    def prior(self) -> NDArray[np.float64]:
        """Lambda0: a weak diagonal prior information (per unit pixel variance)."""
        return np.diag(1.0 / (_PRIOR_SIGMA * _PARAM_SCALE) ** 2)

    def covariances(self, points: ArrayLike) -> NDArray[np.float64]:
        """Sigma_c (C, 11, 11) per unit calibration-pixel variance for calibration points (N, 3)."""
        X = np.asarray(points, dtype=float).reshape(-1, 3)
        out = []
        for camera in self.cameras:
            J = parameter_jacobians(camera, X)
            out.append(np.linalg.inv(np.einsum("nki,nkj->ij", J, J) + self.prior()))
        return np.array(out)

    def calibration_m2(self, points: ArrayLike) -> float:
        """Phi / T: the calibration's mean squared 3D error at the test points per unit pixel variance."""
        S = self.covariances(points)
        return float(sum(np.trace(s @ h) for s, h in zip(S, self.H)))

    def predicted_ratio(self, points: ArrayLike, sigma_cal_px: float, sigma_test_px: float) -> float:
        """Predicted RMS 3D error of the calibrated rig over that of the true cameras on the same
        test pixels: sqrt(1 + sigma_cal^2 Phi / (sigma_test^2 mean tr N^-1))."""
        return float(
            np.sqrt(1.0 + sigma_cal_px**2 * self.calibration_m2(points) / (sigma_test_px**2 * self.irreducible_m2))
        )


def frame_sigma_px(sigma_px: float) -> float:
    """Effective pixel noise of one frame: Gaussian sigma, then rounding to integer pixels."""
    return float(np.sqrt(sigma_px**2 + ROUNDING_VARIANCE_PX2))
