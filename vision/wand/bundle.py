"""The bundle adjustment of a wand calibration: every camera and every frame's wand at once.

Unknowns (camera 0 fixes the frame: R_0 = I, t_0 = 0; the wand's length L fixes the scale):

* per camera c: the focal length f_c and principal point (cx_c, cy_c) (square pixels, no skew, no
  distortion: the Wiimote's camera as `wiithrow.vision.camera` models it); for c >= 1 the rotation
  vector w_c (R_c = exp([w_c]x), `geometry.rodrigues`) and the translation t_c;
* per frame k: the wand's centre m_k and its direction, two numbers (alpha_k, beta_k) on the
  tangent plane of the starting direction u0_k (basis e1_k, e2_k, both orthogonal to u0_k):

      u_k = (u0_k + alpha_k e1_k + beta_k e2_k) / ||u0_k + alpha_k e1_k + beta_k e2_k||,
      A_k = m_k + (L / 2) u_k,        B_k = m_k - (L / 2) u_k,

  so the length is L in every frame by construction (5 unknowns a frame instead of 6).

Residuals: for every camera c, frame k and end that camera saw, pixel minus projection,

    x_cam = R_c X + t_c,     (u, v) = (f_c x / z + cx_c, f_c y / z + cy_c),

2 per observation, minimised by `scipy.optimize.least_squares` (trust-region reflective) with a
robust loss, soft L1: rho(r^2) = 2 s^2 (sqrt(1 + r^2 / s^2) - 1) with s = `f_scale_px`, quadratic
within a couple of pixels and linear beyond, so a dot given to the wrong end or a stray reflection
pulls with bounded force. Soft L1 rather than Huber or Cauchy: least_squares weights each
residual's Jacobian row by sqrt(rho' + 2 rho'' r^2), which is 0 on Huber's linear part and
negative on Cauchy's tail, clipped to 1e-8; the iterative LSMR step then fails on those rows
(measured here: a Huber fit took no step at all).

Each observation's two residuals depend only on its camera's 3 or 9 unknowns and its frame's 5:
`jac_sparsity` tells least_squares so, which then estimates the Jacobian by finite differences in
about 15 evaluations (columns that share no row are perturbed together) and solves each step with
the sparse iterative LSMR, to tight tolerances (with LSMR's default 1e-6 the optimiser stopped
early in the valley where focal length trades against depth). LSMR's thousands of vector products
run with one BLAS thread: on two busy cores OpenBLAS's threads turned each norm of a
10,000-vector into milliseconds of hand-off (measured: a three-camera fit 59 s with two threads,
3.4 s with one).
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np
import scipy.sparse
from numpy.typing import NDArray
from scipy.optimize import least_squares
from threadpoolctl import threadpool_limits

from wiithrow.vision.geometry import compose, rodrigues

#: Robust loss scale (px): residuals well beyond it count linearly (soft L1).
DEFAULT_F_SCALE_PX = 2.0


def rotation_vector(R: NDArray[np.float64]) -> NDArray[np.float64]:
    """The axis-angle vector w with exp([w]x) = R (the inverse of `geometry.rodrigues`)."""
    c = np.clip((np.trace(R) - 1.0) / 2.0, -1.0, 1.0)
    angle = float(np.arccos(c))
    v = np.array([R[2, 1] - R[1, 2], R[0, 2] - R[2, 0], R[1, 0] - R[0, 1]])
    if angle < 1e-9:
        return 0.5 * v
    if np.pi - angle < 1e-6:  # near pi: the axis from R + I
        _, V = np.linalg.eigh(R + R.T)
        near_pi: NDArray[np.float64] = angle * V[:, -1]
        return near_pi
    out: NDArray[np.float64] = angle / (2.0 * np.sin(angle)) * v
    return out


@dataclass(frozen=True)
class BundleResult:
    """The adjusted rig and wand.

    K (C, 3, 3), R (C, 3, 3), t (C, 3): the cameras; frames (M,): which observation frames took
    part; ends (M, 2, 3): the wand's two LEDs in those frames (end 0 at +L/2); residuals_px (n, 2)
    with the observation's camera, frame (an index into `frames`) and end (n,) each; seconds: the
    optimiser's wall time; nfev: residual evaluations; success: scipy's verdict.
    """

    K: NDArray[np.float64]
    R: NDArray[np.float64]
    t: NDArray[np.float64]
    frames: NDArray[np.int64]
    ends: NDArray[np.float64]
    residuals_px: NDArray[np.float64]
    obs_camera: NDArray[np.int64]
    obs_frame: NDArray[np.int64]
    obs_end: NDArray[np.int64]
    seconds: float
    nfev: int
    success: bool

    @property
    def Ps(self) -> NDArray[np.float64]:
        return compose(self.K, self.R, self.t)


class _Problem:
    """The parameter vector's layout, the residuals and the Jacobian's sparsity."""

    def __init__(self, pixels: NDArray[np.float64], frames: NDArray[np.int64], wand_length_m: float) -> None:
        C = pixels.shape[0]
        self.C, self.M, self.half = C, len(frames), 0.5 * wand_length_m
        x = pixels[:, frames]  # (C, M, 2, 2)
        c, k, e = np.nonzero(np.isfinite(x[..., 0]))  # sorted by camera
        self.obs_camera, self.obs_frame, self.obs_end = c.astype(np.int64), k.astype(np.int64), e.astype(np.int64)
        self.observed = x[c, k, e]  # (n, 2)
        self.by_camera = [np.flatnonzero(c == i) for i in range(C)]
        self.sign = np.where(e == 0, 1.0, -1.0)[:, None]
        self.n_camera = 3 * C + 6 * (C - 1)

    def pack(
        self,
        K: NDArray[np.float64],
        R: NDArray[np.float64],
        t: NDArray[np.float64],
        centres: NDArray[np.float64],
    ) -> NDArray[np.float64]:
        intrinsics = np.column_stack([K[:, 0, 0], K[:, 0, 2], K[:, 1, 2]]).ravel()
        poses = np.concatenate([np.concatenate([rotation_vector(R[c]), t[c]]) for c in range(1, self.C)])
        frames = np.column_stack([centres, np.zeros((self.M, 2))]).ravel()
        return np.concatenate([intrinsics, poses, frames])

    def basis(self, directions: NDArray[np.float64]) -> None:
        """The tangent bases e1, e2 (M, 3) of the starting directions u0 (M, 3)."""
        self.u0 = directions
        helper = np.where(np.abs(directions[:, :1]) < 0.9, [[1.0, 0.0, 0.0]], [[0.0, 1.0, 0.0]])
        e1 = np.cross(directions, helper)
        self.e1 = e1 / np.linalg.norm(e1, axis=1, keepdims=True)
        self.e2 = np.cross(directions, self.e1)

    def unpack(
        self, x: NDArray[np.float64]
    ) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
        """K (C, 3, 3), R (C, 3, 3), t (C, 3) and the ends (M, 2, 3) of parameters x."""
        C = self.C
        f, cx, cy = x[: 3 * C].reshape(C, 3).T
        K = np.zeros((C, 3, 3))
        K[:, 0, 0] = K[:, 1, 1] = f
        K[:, 0, 2], K[:, 1, 2], K[:, 2, 2] = cx, cy, 1.0
        poses = x[3 * C : self.n_camera].reshape(C - 1, 6)
        R = np.stack([np.eye(3)] + [rodrigues(p[:3]) for p in poses])
        t = np.vstack([np.zeros(3), poses[:, 3:]])
        frame = x[self.n_camera :].reshape(self.M, 5)
        u = self.u0 + frame[:, 3:4] * self.e1 + frame[:, 4:5] * self.e2
        u /= np.linalg.norm(u, axis=1, keepdims=True)
        ends = np.stack([frame[:, :3] + self.half * u, frame[:, :3] - self.half * u], axis=1)
        return K, R, t, ends

    def residuals(self, x: NDArray[np.float64]) -> NDArray[np.float64]:
        K, R, t, ends = self.unpack(x)
        out = np.empty_like(self.observed)
        for c, rows in enumerate(self.by_camera):
            X = ends[self.obs_frame[rows], self.obs_end[rows]]
            Xc = X @ R[c].T + t[c]
            out[rows] = K[c, 0, 0] * Xc[:, :2] / Xc[:, 2:3] + K[c, :2, 2] - self.observed[rows]
        return out.ravel()

    def sparsity(self) -> scipy.sparse.csr_matrix:
        """Which unknowns each residual depends on (2n x unknowns)."""
        C, n = self.C, len(self.obs_camera)
        cols: list[NDArray[np.int64]] = []
        for c in range(C):
            cam_cols = list(range(3 * c, 3 * c + 3))
            if c > 0:
                cam_cols += list(range(3 * C + 6 * (c - 1), 3 * C + 6 * c))
            cols.append(np.array(cam_cols, dtype=np.int64))
        block = np.full((n, 14), -1, dtype=np.int64)  # up to 9 camera columns, then the frame's 5
        for c in range(C):
            block[self.by_camera[c], : len(cols[c])] = cols[c]
        block[:, 9:] = self.n_camera + 5 * self.obs_frame[:, None] + np.arange(5)
        valid = block >= 0
        obs = np.broadcast_to(np.arange(n)[:, None], block.shape)[valid]
        r = np.concatenate([2 * obs, 2 * obs + 1])
        cc = np.concatenate([block[valid], block[valid]])
        return scipy.sparse.csr_matrix((np.ones(r.size), (r, cc)), shape=(2 * n, self.n_camera + 5 * self.M))


def bundle_adjust(
    pixels: NDArray[np.float64],
    frames: NDArray[np.int64],
    K: NDArray[np.float64],
    R: NDArray[np.float64],
    t: NDArray[np.float64],
    ends: NDArray[np.float64],
    wand_length_m: float,
    *,
    f_scale_px: float = DEFAULT_F_SCALE_PX,
    max_nfev: int = 200,
) -> BundleResult:
    """Adjust cameras (K, R, t as starting values; camera 0 stays at R = I, t = 0) and the wand in
    `frames` (ends (M, 2, 3) as starting values, from any triangulation) to the labelled pixels
    (C, N, 2, 2) (end 0 of every camera is one LED; see `ends.label_frames`)."""
    problem = _Problem(pixels, frames, wand_length_m)
    direction = ends[:, 0] - ends[:, 1]
    problem.basis(direction / np.linalg.norm(direction, axis=1, keepdims=True))
    x0 = problem.pack(K, R, t, ends.mean(axis=1))
    start = time.perf_counter()
    with threadpool_limits(limits=1, user_api="blas"):  # see the module docstring
        fit = least_squares(
            problem.residuals,
            x0,
            jac_sparsity=problem.sparsity(),
            method="trf",
            tr_solver="lsmr",
            loss="soft_l1",
            f_scale=f_scale_px,
            x_scale="jac",
            ftol=1e-10,
            xtol=1e-10,
            max_nfev=max_nfev,
            tr_options={"atol": 1e-10, "btol": 1e-10},
        )
    seconds = time.perf_counter() - start
    K_fit, R_fit, t_fit, ends_fit = problem.unpack(fit.x)
    return BundleResult(
        K_fit,
        R_fit,
        t_fit,
        frames,
        ends_fit,
        problem.residuals(fit.x).reshape(-1, 2),
        problem.obs_camera,
        problem.obs_frame,
        problem.obs_end,
        seconds,
        int(fit.nfev),
        bool(fit.success),
    )
