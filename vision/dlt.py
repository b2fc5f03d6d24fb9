"""Calibration of one camera by the Direct Linear Transform: P from known 3D points and their pixels.

A camera maps a point X = (x, y, z) to the pixel (u, v) by the 3x4 projection matrix P:

    u = (p11 x + p12 y + p13 z + p14) / (p31 x + p32 y + p33 z + p34)
    v = (p21 x + p22 y + p23 z + p24) / (p31 x + p32 y + p33 z + p34)                      (paper eq. 15)

Each point gives two equations linear in the entries of P. The methods:

* ``"paper"`` -- the seed paper's solve (eq. 16-18): fix p34 = 1, so the 11 remaining unknowns
  a = (p11..p33) solve A a = b with rows

      [x y z 1 0 0 0 0 -u x -u y -u z] a = u,   [0 0 0 0 x y z 1 -v x -v y -v z] a = v,

  by the pseudo-inverse a = (A^T A)^-1 A^T b. Unnormalised; breaks down when the world origin lies
  near the camera's focal plane (then p34 ~ 0 and cannot be 1).
* ``"normalized"`` -- Hartley's normalised DLT: translate the pixels to their centroid and scale
  them to mean distance sqrt(2), the world points likewise to sqrt(3); solve the homogeneous system
  A p = 0 (12 unknowns, ||p|| = 1) by SVD (p = the right singular vector of the smallest singular
  value), and undo the normalisations: P = T^-1 P_n U.
* ``"refined"`` (default) -- the normalised solution refined by Levenberg-Marquardt
  (scipy.optimize.least_squares) on the reprojection error sum_i ||x_i - pi(P, X_i)||^2: the
  maximum-likelihood fit under Gaussian pixel noise. P is parametrised minimally by its 11 degrees
  of freedom, P = K [R | -R C] with K upper-triangular (fx, skew, cx, fy, cy), R = exp([w]x) and the
  centre C.
* ``"robust"`` -- the paper's "recursive pseudo-inverse" (inaccurate points weigh less) done
  properly: a seeded RANSAC over minimal 6-point samples finds a consensus set, then the refinement
  runs with a Cauchy loss (iteratively re-weighted least squares in effect) so gross outliers lose
  their influence, and a final refit uses the inliers only.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Literal

import numpy as np
import scipy.linalg
from numpy.typing import ArrayLike, NDArray
from scipy.optimize import least_squares

from wiithrow.vision.errors import CalibrationError
from wiithrow.vision.geometry import homogeneous, project, reprojection_errors, rodrigues

Method = Literal["paper", "normalized", "refined", "robust"]
METHODS: tuple[str, ...] = ("paper", "normalized", "refined", "robust")
MIN_POINTS = 6

#: A fit whose RMS reprojection error exceeds this many pixels describes no camera.
DEFAULT_MAX_RMS_PX = 20.0
#: Smallest/largest singular value of the centred world points below which they are flat.
DEGENERACY_RATIO = 1e-3
#: Residual (px) above which the robust method calls a point an outlier.
ROBUST_INLIER_PX = 6.0


@dataclass(frozen=True)
class Decomposition:
    """P = K [R | t] split into intrinsics K (K[2,2] = 1), rotation R (frame -> camera) and t.

    `center` is the optical centre in the calibration frame (C = -R^T t). `mirrored` is True when
    the image is a mirror image of a right-handed pinhole view (then K[0,0] < 0, R stays a proper
    rotation and points in front of the camera keep a positive depth).
    """

    K: NDArray[np.float64]
    R: NDArray[np.float64]
    t: NDArray[np.float64]
    center: NDArray[np.float64]
    mirrored: bool


@dataclass(frozen=True)
class CalibratedCamera:
    """A camera fitted by `calibrate`: its projection matrix and how well it fits its data.

    `residuals_px[i]` is the reprojection error of calibration point i (pixels); `inliers` marks
    the points the fit trusts (all of them, except for the robust method).
    """

    P: NDArray[np.float64]
    method: str
    world: NDArray[np.float64] = field(repr=False)
    image: NDArray[np.float64] = field(repr=False)
    residuals_px: NDArray[np.float64] = field(repr=False)
    inliers: NDArray[np.bool_] = field(repr=False)
    image_size: tuple[int, int] = (1024, 768)
    name: str = "cam0"

    @property
    def rms_px(self) -> float:
        """RMS reprojection error of the inlier calibration points (pixels); NaN without any (a
        camera built from a known P, not fitted)."""
        r = self.residuals_px[self.inliers]
        return float(np.sqrt(np.mean(r**2))) if r.size else float("nan")

    def project(self, points: ArrayLike) -> NDArray[np.float64]:
        """Pixels (N, 2) of points (N, 3) in the calibration frame; NaN behind the camera."""
        return project(self.P, points)

    def decompose(self) -> Decomposition:
        """P = K [R | t] by RQ decomposition (see `decompose`)."""
        return decompose(self.P)

    def to_dict(self) -> dict[str, Any]:
        """A JSON-ready description: P, its decomposition, the fit's residuals and method."""
        d = self.decompose()
        return {
            "name": self.name,
            "method": self.method,
            "image_size": list(self.image_size),
            "P": self.P.tolist(),
            "K": d.K.tolist(),
            "R": d.R.tolist(),
            "t": d.t.tolist(),
            "center": d.center.tolist(),
            "mirrored": d.mirrored,
            "rms_px": self.rms_px,
            "residuals_px": self.residuals_px.tolist(),
            "inliers": self.inliers.tolist(),
            "world": self.world.tolist(),
            "image": self.image.tolist(),
        }

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> CalibratedCamera:
        """Inverse of `to_dict` (raises KeyError/ValueError on a malformed dict)."""
        P = np.asarray(data["P"], dtype=float).reshape(3, 4)
        world = np.asarray(data.get("world", []), dtype=float).reshape(-1, 3)
        image = np.asarray(data.get("image", []), dtype=float).reshape(-1, 2)
        residuals = np.asarray(data.get("residuals_px", []), dtype=float).reshape(-1)
        inliers = np.asarray(data.get("inliers", [True] * residuals.size), dtype=bool).reshape(-1)
        width, height = data.get("image_size", (1024, 768))
        return cls(
            P,
            str(data.get("method", "unknown")),
            world,
            image,
            residuals,
            inliers,
            (int(width), int(height)),
            str(data.get("name", "cam0")),
        )


# --------------------------------------------------------------------------------------------
# P = K [R | t]


def decompose(P: ArrayLike) -> Decomposition:
    """Split P into K [R | t] by an RQ decomposition of its left 3x3 block M.

    Convention: P's overall sign is such that points in front of the camera have w = (P X~)_3 > 0
    (`calibrate` fixes it so). Then P = lambda K [R | t] with lambda > 0, and since K's third row is
    (0, 0, 1), det M = lambda^3 det(K) det(R) has the sign of det(K): negative means a mirrored image
    (K[0,0] < 0 with R a proper rotation).

        M = K0 R0 (RQ),  D = diag(sign(diag K0)):  M = (K0 D)(D R0)     K0 D has a positive diagonal
        det(D R0) < 0  ->  K = K0 D F, R = F D R0 with F = diag(-1, 1, 1)   (mirrored)
        t = K^-1 p4,  K <- K / K[2,2],  C = -R^T t
    """
    P = np.asarray(P, dtype=float).reshape(3, 4)
    M = P[:, :3]
    if not np.all(np.isfinite(P)) or abs(np.linalg.det(M)) < 1e-12 * max(np.abs(M).max(), 1e-300) ** 3:
        raise CalibrationError("P has a singular left 3x3 block: it is not a finite camera")
    K, R = scipy.linalg.rq(M)
    D = np.diag(np.sign(np.diag(K)))
    K, R = K @ D, D @ R
    mirrored = bool(np.linalg.det(R) < 0)
    if mirrored:
        F = np.diag([-1.0, 1.0, 1.0])
        K, R = K @ F, F @ R
    t = np.linalg.solve(K, P[:, 3])
    K = K / K[2, 2]
    return Decomposition(K=K, R=R, t=t, center=-R.T @ t, mirrored=mirrored)


# --------------------------------------------------------------------------------------------
# Input checks


def _as_points(world: ArrayLike, image: ArrayLike) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Validate calibration input; raise CalibrationError saying what is wrong and what to do."""
    try:
        X = np.asarray(world, dtype=float)
        x = np.asarray(image, dtype=float)
    except (TypeError, ValueError) as exc:
        raise CalibrationError(f"calibration points must be numeric arrays ({exc})") from None
    if X.ndim != 2 or X.shape[1] != 3:
        raise CalibrationError(f"world points must have shape (N, 3), got {X.shape}")
    if x.ndim != 2 or x.shape[1] != 2:
        raise CalibrationError(f"image points must have shape (N, 2), got {x.shape}")
    if X.shape[0] != x.shape[0]:
        raise CalibrationError(f"{X.shape[0]} world points but {x.shape[0]} image points: give one pixel per 3D point")
    bad = ~(np.isfinite(X).all(axis=1) & np.isfinite(x).all(axis=1))
    if bad.any():
        rows = np.flatnonzero(bad)
        raise CalibrationError(
            f"{bad.sum()} calibration point(s) contain NaN or inf (rows {_list(rows)}): "
            "drop the points this camera did not see before calibrating it"
        )
    if X.shape[0] < MIN_POINTS:
        raise CalibrationError(
            f"a camera needs at least {MIN_POINTS} calibration points (11 unknowns, 2 equations "
            f"per point), got {X.shape[0]}; the paper recommends 30 or more"
        )
    scale = max(float(np.ptp(X, axis=0).max()), 1e-300)
    _, first, counts = np.unique(np.round(X / (scale * 1e-9)), axis=0, return_index=True, return_counts=True)
    if (counts > 1).any():
        dup = np.flatnonzero(np.isin(np.arange(len(X)), first[counts > 1], invert=False))
        raise CalibrationError(
            f"duplicated 3D calibration points (first copies at rows {_list(dup)}): "
            "each point must be a distinct position; average repeated measurements instead"
        )
    s = np.linalg.svd(X - X.mean(axis=0), compute_uv=False)
    if s[1] <= DEGENERACY_RATIO * s[0]:
        raise CalibrationError(
            "the 3D calibration points are collinear: they cannot determine a camera; spread them through a volume"
        )
    if s[2] <= DEGENERACY_RATIO * s[0]:
        raise CalibrationError(
            "the 3D calibration points are coplanar (rank-deficient DLT): a 3x4 projection matrix "
            "needs points spread in depth as well; add points off the plane"
        )
    return X, x


def _list(indices: NDArray[np.int64], most: int = 8) -> str:
    shown = ", ".join(str(int(i)) for i in indices[:most])
    return shown + (", ..." if len(indices) > most else "")


# --------------------------------------------------------------------------------------------
# Linear solutions


def _normalizing_transform(points: NDArray[np.float64], mean_distance: float) -> NDArray[np.float64]:
    """Similarity T that moves `points` to their centroid and scales them to `mean_distance`."""
    d = points.shape[1]
    centroid = points.mean(axis=0)
    spread = np.linalg.norm(points - centroid, axis=1).mean()
    s = mean_distance / spread if spread > 0 else 1.0
    T = np.eye(d + 1)
    T[:d, :d] *= s
    T[:d, d] = -s * centroid
    return T


def _dlt_rows(X: NDArray[np.float64], x: NDArray[np.float64]) -> NDArray[np.float64]:
    """The 2N x 12 homogeneous system A p = 0 of eq. 15 (X homogeneous (N, 4), x (N, 2))."""
    n = X.shape[0]
    A = np.zeros((2 * n, 12))
    A[0::2, 0:4] = X
    A[0::2, 8:12] = -x[:, :1] * X
    A[1::2, 4:8] = X
    A[1::2, 8:12] = -x[:, 1:2] * X
    return A


def solve_normalized(world: NDArray[np.float64], image: NDArray[np.float64]) -> NDArray[np.float64]:
    """Hartley-normalised homogeneous DLT: P = T^-1 P_n U with P_n from the SVD of A_n."""
    U = _normalizing_transform(world, np.sqrt(3.0))
    T = _normalizing_transform(image, np.sqrt(2.0))
    Xn = homogeneous(world) @ U.T
    xn = (homogeneous(image) @ T.T)[:, :2]
    _, s, Vt = np.linalg.svd(_dlt_rows(Xn, xn))
    if s[-2] <= 1e-10 * s[0]:
        raise CalibrationError(
            "the calibration system is rank-deficient (more than one camera fits the points): "
            "the points are degenerate for a DLT; spread them through the field of view and in depth"
        )
    Pn = Vt[-1].reshape(3, 4)
    return np.linalg.solve(T, Pn @ U)


def solve_paper(world: NDArray[np.float64], image: NDArray[np.float64]) -> NDArray[np.float64]:
    """The paper's eq. 16-18: p34 = 1 and a = pinv(A) b over the 11 remaining entries."""
    X = homogeneous(world)
    A12 = _dlt_rows(X, image)
    A = A12[:, :11]
    b = -A12[:, 11]  # the p34 column moved to the right-hand side: (u, v) per point
    a = np.linalg.pinv(A) @ b
    return np.append(a, 1.0).reshape(3, 4)


def _canonical(P: NDArray[np.float64], world: NDArray[np.float64]) -> NDArray[np.float64]:
    """Scale P so that ||P[2, :3]|| = 1 and the points lie in front (w = depth > 0, median)."""
    P = P / np.linalg.norm(P[2, :3])
    w = homogeneous(world) @ P[2]
    return -P if np.median(w) < 0 else P


# --------------------------------------------------------------------------------------------
# Non-linear refinement on the reprojection error


def _compose(params: NDArray[np.float64], R0: NDArray[np.float64]) -> NDArray[np.float64]:
    """P = K [R | -R C] from (fx, skew, cx, fy, cy, w, C) with R = exp([w]x) R0."""
    fx, skew, cx, fy, cy = params[:5]
    K = np.array([[fx, skew, cx], [0.0, fy, cy], [0.0, 0.0, 1.0]])
    R = rodrigues(params[5:8]) @ R0
    C = params[8:11]
    return K @ np.hstack([R, (-R @ C)[:, None]])


def _compose_jacobian(params: NDArray[np.float64], R0: NDArray[np.float64]) -> NDArray[np.float64]:
    """dP/dtheta (12 x 11) by central differences of `_compose` (a 3x4 product: cheap, accurate)."""
    J = np.empty((12, params.size))
    for k in range(params.size):
        h = 1e-6 * max(1.0, abs(params[k]))
        step = np.zeros_like(params)
        step[k] = h
        J[:, k] = (_compose(params + step, R0) - _compose(params - step, R0)).ravel() / (2 * h)
    return J


def refine(
    P0: NDArray[np.float64],
    world: NDArray[np.float64],
    image: NDArray[np.float64],
    *,
    loss: str = "linear",
    f_scale_px: float = 1.0,
) -> NDArray[np.float64]:
    """Minimise sum_i rho(||x_i - pi(P, X_i)||^2) over the 11 degrees of freedom of P.

    `loss="linear"` is Levenberg-Marquardt on the plain reprojection error (maximum likelihood
    under Gaussian noise); a robust loss ("cauchy", "soft_l1", ...) down-weights large residuals
    with scale `f_scale_px`, which is iteratively re-weighted least squares in effect.
    """
    d = decompose(_canonical(P0, world))
    K = d.K
    x0 = np.concatenate([[K[0, 0], K[0, 1], K[0, 2], K[1, 1], K[1, 2]], np.zeros(3), d.center])
    Xh = homogeneous(world)

    def residuals(params: NDArray[np.float64]) -> NDArray[np.float64]:
        r = project(_compose(params, d.R), world) - image
        return np.nan_to_num(r, nan=1e6).ravel()

    def jacobian(params: NDArray[np.float64]) -> NDArray[np.float64]:
        # Chain rule J = dr/dP . dP/dtheta. With (a, b, w) = P X~ and u = a / w:
        #   du/dP_0j = X~_j / w,  du/dP_2j = -u X~_j / w,  dv/dP_1j = X~_j / w,  dv/dP_2j = -v X~_j / w
        proj = Xh @ _compose(params, d.R).T
        w = proj[:, 2:3]
        u, v = proj[:, 0:1] / w, proj[:, 1:2] / w
        dr_dP = np.zeros((world.shape[0], 2, 12))
        dr_dP[:, 0, 0:4] = Xh / w
        dr_dP[:, 0, 8:12] = -u * Xh / w
        dr_dP[:, 1, 4:8] = Xh / w
        dr_dP[:, 1, 8:12] = -v * Xh / w
        return dr_dP.reshape(-1, 12) @ _compose_jacobian(params, d.R)

    method = "lm" if loss == "linear" and residuals(x0).size >= x0.size else "trf"
    result = least_squares(residuals, x0, jac=jacobian, method=method, loss=loss, f_scale=f_scale_px, x_scale="jac")
    P = _compose(result.x, d.R)
    # Keep the refinement only if it did not make things worse (it never should, but a bad start can).
    if np.sum(reprojection_errors(P, world, image) ** 2) > np.sum(reprojection_errors(P0, world, image) ** 2):
        return P0
    return P


# --------------------------------------------------------------------------------------------
# Robust fit


def solve_robust(
    world: NDArray[np.float64],
    image: NDArray[np.float64],
    rng: np.random.Generator,
    *,
    inlier_px: float = ROBUST_INLIER_PX,
    max_trials: int = 500,
    confidence: float = 0.999,
) -> tuple[NDArray[np.float64], NDArray[np.bool_]]:
    """RANSAC over 6-point samples, Cauchy-loss refinement, then a plain refit on the inliers.

    Returns P and the inlier mask. The number of trials adapts to the inlier ratio w found so far:
    k = log(1 - confidence) / log(1 - w^6).
    """
    n = world.shape[0]
    best_inliers = np.zeros(n, dtype=bool)
    best_cost = np.inf
    trials, needed = 0, max_trials
    while trials < min(needed, max_trials):
        trials += 1
        sample = rng.choice(n, MIN_POINTS, replace=False)
        Xs = world[sample]
        s = np.linalg.svd(Xs - Xs.mean(axis=0), compute_uv=False)
        if s[2] <= DEGENERACY_RATIO * s[0]:
            continue
        try:
            P = solve_normalized(Xs, image[sample])
        except CalibrationError:
            continue
        err = reprojection_errors(P, world, image)
        err = np.where(np.isfinite(err), err, np.inf)
        inliers = err < inlier_px
        cost = np.minimum(err, inlier_px).sum()  # MSAC: truncated cost, ties broken by accuracy
        if cost < best_cost and inliers.sum() >= MIN_POINTS:
            best_cost, best_inliers = cost, inliers
            w = inliers.mean()
            needed = int(np.ceil(np.log(1 - confidence) / np.log(max(1 - w**MIN_POINTS, 1e-12))))
    if best_inliers.sum() < MIN_POINTS:
        raise CalibrationError(
            f"robust calibration found no camera that fits {MIN_POINTS} or more points within "
            f"{inlier_px:g} px: the points do not describe one camera"
        )
    P = solve_normalized(world[best_inliers], image[best_inliers])
    P = refine(P, world, image, loss="cauchy", f_scale_px=inlier_px / 3)
    err = reprojection_errors(P, world, image)
    inliers = np.isfinite(err) & (err < inlier_px)
    if inliers.sum() < MIN_POINTS:
        inliers = best_inliers
    P = refine(solve_normalized(world[inliers], image[inliers]), world[inliers], image[inliers])
    err = reprojection_errors(P, world, image)
    return P, np.isfinite(err) & (err < inlier_px)


# --------------------------------------------------------------------------------------------
# The entry point


def calibrate(
    world: ArrayLike,
    image: ArrayLike,
    method: Method = "refined",
    *,
    image_size: tuple[int, int] = (1024, 768),
    name: str = "cam0",
    max_rms_px: float = DEFAULT_MAX_RMS_PX,
    rng: np.random.Generator | None = None,
) -> CalibratedCamera:
    """Fit one camera's projection matrix to N >= 6 known 3D points (N, 3) and their pixels (N, 2).

    `method` is one of "paper", "normalized", "refined" (default) and "robust" (see the module
    docstring). `rng` seeds the robust method's sampling (default: a fixed seed, so results are
    reproducible). The returned P is scaled so that ||P[2, :3]|| = 1 with the calibration points in
    front of the camera (then (P X~)_3 is their depth in the world's unit).

    Raises CalibrationError for fewer than 6 points, mismatched shapes, NaN/inf, duplicated points,
    collinear or coplanar points, and for a fit whose RMS reprojection error exceeds `max_rms_px`
    or that puts calibration points behind the camera (the data do not describe one camera).
    """
    X, x = _as_points(world, image)
    if method not in METHODS:
        raise CalibrationError(f"unknown calibration method {method!r}; choose one of {', '.join(METHODS)}")
    inliers = np.ones(X.shape[0], dtype=bool)
    if method == "paper":
        P = solve_paper(X, x)
    elif method == "normalized":
        P = solve_normalized(X, x)
    elif method == "refined":
        P = refine(solve_normalized(X, x), X, x)
    else:
        P, inliers = solve_robust(X, x, rng if rng is not None else np.random.default_rng(0))
    if not np.all(np.isfinite(P)) or np.linalg.norm(P[2, :3]) == 0:
        raise CalibrationError(
            f"the {method!r} solve gave no finite camera"
            + (
                ": the world origin is probably near the camera's focal plane; use 'normalized'"
                if method == "paper"
                else ""
            )
        )
    P = _canonical(P, X)
    residuals = reprojection_errors(P, X, x)
    camera = CalibratedCamera(P, method, X, x, np.nan_to_num(residuals, nan=np.inf), inliers, image_size, name)
    behind = (homogeneous(X[inliers]) @ P[2]) <= 0
    if behind.any():
        raise CalibrationError(
            f"the fitted camera {name} puts {int(behind.sum())} calibration point(s) behind it: "
            "the points and pixels do not describe one camera (check their order and units)"
        )
    if not camera.rms_px <= max_rms_px:
        hint = (
            " (the paper's a34 = 1 solve fails when the world origin is near the camera's focal plane: try 'normalized')"
            if method == "paper"
            else ""
        )
        raise CalibrationError(
            f"the {method!r} fit of camera {name} leaves an RMS reprojection error of "
            f"{camera.rms_px:.1f} px (> {max_rms_px:g} px): the 3D points and pixels do not describe "
            f"one camera; check that they are in the same order, in the same units, from one camera{hint}"
        )
    return camera
