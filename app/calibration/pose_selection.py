"""Where the hand should hold the calibration LED: reachable, visible, and spread for a small error.

Owns the choice of the robot-driven calibration's marker positions (in `link1`) and the
measurements that justify it:

1. **Candidates** (`sample_candidates`): configurations of the arm with joint 1 at 0 (so `link1`
   is `base`), drawn uniformly in the joint limits and then by a random walk from the accepted
   ones, kept when the marker (the LED) is
   - in the common field of view of the NOMINAL cameras, `margin_px` inside every image (on
     hardware the true cameras are unknown; a pose they do not see is replaced at run time),
   - at x (distance from the joint-1 axis) in `x_range`,
   - facing the cameras: the angle between the marker frame's z axis (the LED's axis) and the
     direction to the rig's centre at most `max_led_angle_deg`,
   - with the arm's skeleton `floor_clearance_m` above the floor and `rig_clearance_m` away from
     every camera.
   Every candidate is reachable by construction (its configuration is known), so the arm's real
   reach, not an assumed box, bounds the volume. The cloud is thinned to one candidate per voxel
   (the best-facing one), which makes it about uniform in space.

2. **The design criterion**: the expected squared 3D error that the calibration adds at test
   points spread through the same volume (I-optimality), from first-order error propagation of the
   DLT. Camera c has 11 parameters theta_c (fx, fy, skew, cx, cy, rotation w, centre C); with J_ic
   the 2x11 Jacobian of its pixel of calibration point i,

       Sigma_c = (sum_i J_ic^T J_ic / sigma_cal^2 + Lambda0)^-1            (the fit's covariance)

   A test point X_t triangulated from pixels x_t: with A_c = d pi_c / dX (2x3) and
   B_tc = d pi_c / d theta_c (2x11), the linearised least-squares point moves by
   dX = -N_t^-1 sum_c A_c^T B_tc d theta_c,  N_t = sum_c A_c^T A_c, so

       E ||dX_t||^2 = sigma_test^2 tr(N_t^-1)   +   sum_c tr(G_tc Sigma_c G_tc^T),   G_tc = N_t^-1 A_c^T B_tc
                      (pixel noise: the true cameras' error)   (the calibration's share)

   and the design minimises  Phi = sum_c tr(Sigma_c H_c),  H_c = sum_t G_tc^T G_tc.

3. **Selection** (`select_poses`): `"optimal"` adds, one at a time, the candidate whose point
   lowers Phi most (a rank-2 update per camera: the gain of point i is
   tr((sigma^2 I + J Sigma J^T)^-1 J Sigma H Sigma J^T) summed over cameras), keeping every new
   point `min_separation` away from the chosen ones so the design also fills the space;
   `"random"` draws candidates uniformly (the baseline). Both are ordered for short moves.

`evaluate_design` measures a design without the robot (ideal positions, simulated pixels averaged
over frames as the calibration does): leave-one-out error and the ratio of the calibrated rig's
test error to the true cameras' on the same noisy test pixels. `rig_coverage` measures what a rig
sees of the throwing area.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray

from wiithrow.app.errors import AppError
from wiithrow.robot import ArmModel
from wiithrow.vision import calibrate, leave_one_out, triangulate
from wiithrow.vision.camera import WiimoteCamera

Design = Literal["optimal", "random"]
DESIGNS: tuple[str, ...] = ("optimal", "random")

#: Pixel noise of one frame: sigma before rounding plus the rounding itself (uniform, variance 1/12).
ROUNDING_VARIANCE_PX2 = 1.0 / 12.0


# --------------------------------------------------------------------------------------------
# Candidates


@dataclass(frozen=True)
class PoseCandidates:
    """Reachable marker positions the cameras see: `positions` (M, 3) in link1, the configurations
    `q` (M, nq) with joint 1 at 0 that put the marker there, and the LED's angle to the rig
    `led_angle_rad` (M,)."""

    positions: NDArray[np.float64]
    q: NDArray[np.float64]
    led_angle_rad: NDArray[np.float64]
    voxel_m: float

    def __len__(self) -> int:
        return int(self.positions.shape[0])

    @property
    def volume_m3(self) -> float:
        """The volume the candidates fill (occupied voxels)."""
        return len(self) * self.voxel_m**3

    def subset(self, index: ArrayLike) -> PoseCandidates:
        i = np.asarray(index, dtype=np.int64)
        return PoseCandidates(self.positions[i], self.q[i], self.led_angle_rad[i], self.voxel_m)


def in_common_view(cameras: Sequence[WiimoteCamera], points: ArrayLike, margin_px: float = 20.0) -> NDArray[np.bool_]:
    """Which points (N, 3) every camera sees `margin_px` inside its image (and in front of it)."""
    X = np.asarray(points, dtype=float).reshape(-1, 3)
    ok = np.ones(len(X), dtype=bool)
    for camera in cameras:
        uv = camera.project(X)
        with np.errstate(invalid="ignore"):
            ok &= (
                np.isfinite(uv).all(axis=1)
                & (uv[:, 0] >= margin_px)
                & (uv[:, 0] <= camera.width - 1 - margin_px)
                & (uv[:, 1] >= margin_px)
                & (uv[:, 1] <= camera.height - 1 - margin_px)
            )
    return ok


def rig_center(cameras: Sequence[WiimoteCamera]) -> NDArray[np.float64]:
    """Mean of the cameras' optical centres (in their frame)."""
    return np.mean([c.center for c in cameras], axis=0)


def _segment_distance(
    points: NDArray[np.float64], a: NDArray[np.float64], b: NDArray[np.float64]
) -> NDArray[np.float64]:
    """Distance (P, S) from each point (P, 3) to each segment a[s] -> b[s] (S, 3)."""
    d = b - a
    L2 = np.maximum((d * d).sum(axis=1), 1e-18)
    s = np.clip(((points[:, None, :] - a[None]) * d[None]).sum(axis=2) / L2, 0.0, 1.0)
    closest = a[None] + s[..., None] * d[None]
    return np.linalg.norm(points[:, None, :] - closest, axis=2)


class PoseCheck:
    """Accept or reject one configuration as a calibration pose (joint 1 is ignored: everything is
    checked in link1, which turns with it)."""

    def __init__(
        self,
        arm: ArmModel,
        cameras: Sequence[WiimoteCamera],
        x_range: tuple[float, float] = (0.0, np.inf),
        margin_px: float = 20.0,
        max_led_angle_deg: float = 60.0,
        floor_clearance_m: float = 0.05,
        rig_clearance_m: float = 0.10,
    ) -> None:
        self.arm, self.cameras = arm, list(cameras)
        self.x_range, self.margin_px = x_range, margin_px
        self.cos_led = np.cos(np.deg2rad(max_led_angle_deg))
        self.floor, self.clearance = floor_clearance_m, rig_clearance_m
        self.centers = np.array([c.center for c in self.cameras])
        self.rig = rig_center(self.cameras)
        q0 = arm.home.copy()
        q0[0] = 0.0
        T = arm.frame_placement(q0, "link1")  # link1 depends on q1 only: constant at q1 = 0
        self.R1, self.o1 = T[:3, :3], T[:3, 3]

    def __call__(self, q: NDArray[np.float64]) -> tuple[NDArray[np.float64], float] | None:
        """(position in link1, LED angle) if q is acceptable, else None."""
        q = np.array(q, dtype=float)
        q[0] = 0.0
        T = self.arm.frame_placement(q, "marker")
        p = (T[:3, 3] - self.o1) @ self.R1
        if not self.x_range[0] <= p[0] <= self.x_range[1]:
            return None
        if not in_common_view(self.cameras, p[None], self.margin_px)[0]:
            return None
        to_rig = self.rig - p
        cos = float((T[:3, 2] @ self.R1) @ to_rig / np.linalg.norm(to_rig))
        if cos < self.cos_led:
            return None
        skeleton = (self.arm.collision_points(q) - self.o1) @ self.R1
        if skeleton[:, 2].min() < self.floor:
            return None
        chain = np.vstack([np.zeros((1, 3)), skeleton])
        if _segment_distance(self.centers, chain[:-1], chain[1:]).min() < self.clearance:
            return None
        return p, float(np.arccos(np.clip(cos, -1.0, 1.0)))


def sample_candidates(
    arm: ArmModel,
    cameras: Sequence[WiimoteCamera],
    rng: np.random.Generator,
    *,
    x_range: tuple[float, float] = (0.45, 1.0),
    margin_px: float = 20.0,
    max_led_angle_deg: float = 60.0,
    floor_clearance_m: float = 0.05,
    rig_clearance_m: float = 0.10,
    voxel_m: float = 0.03,
    n_uniform: int = 3000,
    n_walk: int = 5000,
    walk_sigma_rad: float = 0.25,
) -> PoseCandidates:
    """Reachable, visible, LED-facing marker positions (see the module docstring), one per voxel.

    Raises AppError when no configuration of the arm puts the marker where the cameras see it.
    """
    check = PoseCheck(arm, cameras, x_range, margin_px, max_led_angle_deg, floor_clearance_m, rig_clearance_m)
    lo, hi = arm.lower.copy(), arm.upper.copy()
    lo[0] = hi[0] = 0.0
    qs, ps, angles = [], [], []

    def consider(q: NDArray[np.float64]) -> None:
        got = check(q)
        if got is not None:
            qs.append(q)
            ps.append(got[0])
            angles.append(got[1])

    # the home posture is usually in front of the arm: try it first
    consider(arm.clip(np.where(np.arange(arm.nq) == 0, 0.0, arm.home)))
    drawn = 0
    while drawn < n_uniform or (len(qs) < 3 and drawn < 5 * n_uniform):  # arms with wide limits need more
        for q in rng.uniform(lo, hi, (min(n_uniform, 1000), arm.nq)):
            consider(q)
        drawn += min(n_uniform, 1000)
    if not qs:
        raise AppError(
            f"arm '{arm.name}': none of {drawn} random configurations puts the marker where every camera "
            f"sees it at x {x_range[0]:.2f}-{x_range[1]:.2f} m with the LED facing the rig: move the rig "
            "(settings rig.center, rig.pitch_down_deg) in front of the arm's reach"
        )
    step = np.where(np.arange(arm.nq) == 0, 0.0, walk_sigma_rad)
    for _ in range(n_walk):
        q = qs[int(rng.integers(len(qs)))] + rng.normal(0.0, 1.0, arm.nq) * step
        consider(np.clip(q, lo, hi))
    P, Q, A = np.array(ps), np.array(qs), np.array(angles)
    # one candidate per voxel: the one whose LED faces the rig best
    keys = np.floor(P / voxel_m).astype(np.int64)
    order = np.lexsort((A, keys[:, 2], keys[:, 1], keys[:, 0]))
    k = keys[order]
    first = np.ones(len(order), dtype=bool)
    first[1:] = np.any(k[1:] != k[:-1], axis=1)
    keep = order[first]
    return PoseCandidates(P[keep], Q[keep], A[keep], voxel_m)


# --------------------------------------------------------------------------------------------
# The design criterion


#: Scale of each camera parameter for the weak prior Lambda0 and the finite differences:
#: fx, fy, skew, cx, cy (px); rotation (rad); centre (m).
_PARAM_SCALE = np.array([100.0, 100.0, 100.0, 100.0, 100.0, 0.1, 0.1, 0.1, 0.1, 0.1, 0.1])
_PRIOR_SIGMA = 1e3  # the prior allows each parameter 1000 scales: weak, only keeps Sigma finite


def _rotation(w: NDArray[np.float64]) -> NDArray[np.float64]:
    """Rodrigues: exp([w]x)."""
    theta = float(np.linalg.norm(w))
    if theta < 1e-12:
        return np.eye(3)
    k = w / theta
    Kx = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    return np.eye(3) + np.sin(theta) * Kx + (1 - np.cos(theta)) * Kx @ Kx


def _camera_P(camera: WiimoteCamera, theta: NDArray[np.float64]) -> NDArray[np.float64]:
    """P = K [R | -R C] of `camera` perturbed by theta (11,): K entries, rotation, centre."""
    K = camera.K.copy()
    K[0, 0] += theta[0]
    K[1, 1] += theta[1]
    K[0, 1] += theta[2]
    K[0, 2] += theta[3]
    K[1, 2] += theta[4]
    R = _rotation(theta[5:8]) @ camera.R
    C = camera.center + theta[8:11]
    return K @ np.hstack([R, (-R @ C)[:, None]])


def _project(P: NDArray[np.float64], X: NDArray[np.float64]) -> NDArray[np.float64]:
    x = X @ P[:, :3].T + P[:, 3]
    return x[:, :2] / x[:, 2:3]


def parameter_jacobians(camera: WiimoteCamera, points: ArrayLike) -> NDArray[np.float64]:
    """d pixel / d theta (N, 2, 11) of `camera`'s 11 parameters at points (N, 3), central differences."""
    X = np.asarray(points, dtype=float).reshape(-1, 3)
    J = np.empty((len(X), 2, 11))
    for k in range(11):
        h = np.zeros(11)
        h[k] = 1e-4 * _PARAM_SCALE[k]
        J[:, :, k] = (_project(_camera_P(camera, h), X) - _project(_camera_P(camera, -h), X)) / (2 * h[k])
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
    """First-order error propagation of a rig calibrated on chosen points (module docstring, 2.).

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


def greedy_optimal(
    model: ErrorModel, candidates: NDArray[np.float64], n: int, *, min_separation_m: float = 0.0
) -> NDArray[np.int64]:
    """Indices of `n` candidates chosen greedily to minimise Phi (module docstring, 3.)."""
    X = np.asarray(candidates, dtype=float)
    J = np.stack([parameter_jacobians(c, X) for c in model.cameras])  # (C, M, 2, 11)
    info = np.stack([model.prior() for _ in model.cameras])  # (C, 11, 11) information, unit pixel variance
    available = np.ones(len(X), dtype=bool)
    chosen: list[int] = []
    for _ in range(n):
        if not available.any():  # separation too strict: relax it
            available = np.ones(len(X), dtype=bool)
            available[chosen] = False
            min_separation_m = 0.0
        gain = np.zeros(len(X))
        S = np.linalg.inv(info)  # Sigma_c, recomputed from the information (stabler than downdating)
        for c in range(len(model.cameras)):
            JS = J[c] @ S[c]  # (M, 2, 11)
            D = JS @ J[c].transpose(0, 2, 1) + np.eye(2)  # sigma^2 I + J Sigma J^T, sigma = 1
            W = JS @ model.H[c] @ JS.transpose(0, 2, 1)  # J Sigma H Sigma J^T
            det = D[:, 0, 0] * D[:, 1, 1] - D[:, 0, 1] * D[:, 1, 0]
            # tr(D^-1 W) with the 2x2 inverse in closed form
            gain += (
                D[:, 1, 1] * W[:, 0, 0] + D[:, 0, 0] * W[:, 1, 1] - D[:, 0, 1] * W[:, 1, 0] - D[:, 1, 0] * W[:, 0, 1]
            ) / det
        gain[~available] = -np.inf
        i = int(np.argmax(gain))
        chosen.append(i)
        info += J[:, i].transpose(0, 2, 1) @ J[:, i]  # the point's information, every camera
        available &= np.linalg.norm(X - X[i], axis=1) >= min_separation_m
        available[i] = False
    return np.array(chosen, dtype=np.int64)


def travel_order(positions: ArrayLike, start: ArrayLike | None = None) -> NDArray[np.int64]:
    """A short path through the positions (N, 3): nearest neighbour from the one closest to `start`."""
    X = np.asarray(positions, dtype=float).reshape(-1, 3)
    left = list(range(len(X)))
    here = X.mean(axis=0) if start is None else np.asarray(start, dtype=float)
    order = []
    while left:
        d = np.linalg.norm(X[left] - here, axis=1)
        i = left.pop(int(np.argmin(d)))
        order.append(i)
        here = X[i]
    return np.array(order, dtype=np.int64)


# --------------------------------------------------------------------------------------------
# Plans


@dataclass(frozen=True)
class PosePlan:
    """Marker positions for a calibration, in `link1`, in the order to visit them.

    `positions` (N, 3) and `q` (N, nq): the chosen poses and configurations (joint 1 at 0) known to
    reach them; `reserve_positions`/`reserve_q`: the other candidates, to replace a pose the
    cameras do not see; `predicted_ratio`: the error model's RMS ratio of the calibrated rig to the
    true cameras (at `sigma_cal_px` for the calibration, one frame's noise for the test points).
    """

    design: str
    positions: NDArray[np.float64]
    q: NDArray[np.float64]
    reserve_positions: NDArray[np.float64]
    reserve_q: NDArray[np.float64]
    predicted_ratio: float
    test_points: NDArray[np.float64] = field(repr=False)
    frame: str = "link1"

    def __len__(self) -> int:
        return int(self.positions.shape[0])


def select_poses(
    arm: ArmModel | None,
    cameras: Sequence[WiimoteCamera],
    n: int,
    rng: np.random.Generator,
    *,
    design: Design = "optimal",
    candidates: PoseCandidates | None = None,
    n_test: int = 300,
    sigma_px: float = 0.5,
    frames: int = 10,
    separation: float = 0.6,
    start: ArrayLike | None = None,
    **candidate_options,
) -> PosePlan:
    """Choose `n` marker positions (link1) for a robot-driven calibration.

    `arm`: the arm (only needed to draw candidates); `cameras`: the nominal cameras; `design`: "optimal" (greedy I-optimal with a minimum
    separation of `separation` times the mean spacing (V / n)^(1/3)) or "random" (uniform over the
    candidates); `candidates`: reuse a `sample_candidates` result (else one is drawn with
    `candidate_options`); `sigma_px`, `frames`: the pixel noise and the frames averaged per pose,
    for the predicted ratio; `start`: where the marker is now (link1), for the visiting order.
    """
    if design not in DESIGNS:
        raise AppError(f"unknown pose design {design!r}; choose one of {', '.join(DESIGNS)}")
    if n < 6:
        raise AppError(f"a calibration needs at least 6 poses (11 unknowns per camera), got {n}")
    if candidates is None and arm is None:
        raise AppError("select_poses needs the arm (to find reachable poses) or ready candidates")
    cand = candidates if candidates is not None else sample_candidates(arm, cameras, rng, **candidate_options)
    if len(cand) < n:
        raise AppError(
            f"only {len(cand)} distinct reachable marker positions in the cameras' common view for {n} poses: "
            "ask for fewer poses or widen the volume (x_range, max_led_angle_deg)"
        )
    test = cand.positions[rng.choice(len(cand), min(n_test, len(cand)), replace=False)]
    model = ErrorModel.build(cameras, test)
    if design == "optimal":
        spacing = (cand.volume_m3 / n) ** (1.0 / 3.0)
        chosen = greedy_optimal(model, cand.positions, n, min_separation_m=separation * spacing)
    else:
        chosen = rng.choice(len(cand), n, replace=False)
    chosen = chosen[travel_order(cand.positions[chosen], start)]
    rest = np.setdiff1d(np.arange(len(cand)), chosen)
    sigma = frame_sigma_px(sigma_px)
    ratio = model.predicted_ratio(cand.positions[chosen], sigma / np.sqrt(frames), sigma)
    return PosePlan(design, cand.positions[chosen], cand.q[chosen], cand.positions[rest], cand.q[rest], ratio, test)


# --------------------------------------------------------------------------------------------
# Measuring a design without the robot


@dataclass(frozen=True)
class DesignScore:
    """A design's measured quality: leave-one-out mean 3D error (m), the calibrated rig's mean test
    error (m), the true cameras' on the same pixels (m) (their ratio), and the calibration's own
    share: the mean distance between the points the calibrated and the true cameras triangulate
    from the same pixels (m; free of the test pixels' noise, so it separates designs best)."""

    loo_m: float
    test_m: float
    true_test_m: float
    calibration_m: float

    @property
    def ratio(self) -> float:
        return self.test_m / self.true_test_m


def averaged_pixels(
    cameras: Sequence[WiimoteCamera],
    points: ArrayLike,
    rng: np.random.Generator,
    *,
    sigma_px: float = 0.5,
    frames: int = 10,
) -> NDArray[np.float64]:
    """Pixels (C, N, 2) of still points averaged over `frames` noisy, rounded frames (NaN if unseen)."""
    X = np.asarray(points, dtype=float).reshape(-1, 3)
    stack = np.stack([[c.observe(X, rng, sigma_px=sigma_px, max_blobs=None) for c in cameras] for _ in range(frames)])
    return stack.mean(axis=0)


def evaluate_design(
    cameras: Sequence[WiimoteCamera],
    positions: ArrayLike,
    test_points: ArrayLike,
    rng: np.random.Generator,
    *,
    sigma_px: float = 0.5,
    frames: int = 10,
    method: str = "refined",
    cross_validate: bool = True,
) -> DesignScore:
    """Calibrate ideal cameras on `positions` (pixels averaged over `frames` frames, as the robot
    calibration takes them) and measure it: leave-one-out error, and mean 3D error on one noisy
    frame of each test point against the true cameras' on the same pixels."""
    X = np.asarray(positions, dtype=float)
    image = averaged_pixels(cameras, X, rng, sigma_px=sigma_px, frames=frames)
    Ps = np.stack([calibrate(X, image[c], method).P for c in range(len(cameras))])
    loo = leave_one_out(X, image, method).mean if cross_validate else float("nan")
    return score_calibration(Ps, cameras, test_points, rng, sigma_px=sigma_px, loo_m=loo)


def score_calibration(
    Ps: ArrayLike,
    cameras: Sequence[WiimoteCamera],
    test_points: ArrayLike,
    rng: np.random.Generator,
    *,
    sigma_px: float = 0.5,
    loo_m: float = float("nan"),
) -> DesignScore:
    """Test calibrated projection matrices (C, 3, 4) against the true `cameras`: one noisy, rounded
    frame of each test point (N, 3), triangulated by both (see DesignScore)."""
    T = np.asarray(test_points, dtype=float).reshape(-1, 3)
    test_image = np.stack([c.observe(T, rng, sigma_px=sigma_px, max_blobs=None) for c in cameras])
    calibrated = triangulate(np.asarray(Ps, dtype=float), test_image).points
    true = triangulate(np.stack([c.P for c in cameras]), test_image).points
    err = np.linalg.norm(calibrated - T, axis=1)
    true_err = np.linalg.norm(true - T, axis=1)
    return DesignScore(
        float(loo_m),
        float(np.nanmean(err)),
        float(np.nanmean(true_err)),
        float(np.nanmean(np.linalg.norm(calibrated - true, axis=1))),
    )


# --------------------------------------------------------------------------------------------
# What a rig sees of the throwing area


@dataclass(frozen=True)
class RigCoverage:
    """The part of the throw plane (y = 0 of link1: x distance, z height) both cameras see.

    `fraction`: of the grid x in `x_m`, z in `z_m`; `y_half_width`: for each x of `widths_x`, the
    half-width (m) of the common view at z = 0 and z = z_max (the smaller), NaN if unseen.
    """

    x_m: tuple[float, float]
    z_m: tuple[float, float]
    margin_px: float
    fraction: float
    missed: list[tuple[float, float]]
    widths_x: tuple[float, ...]
    y_half_width: tuple[float, ...]


def rig_coverage(
    cameras: Sequence[WiimoteCamera],
    *,
    x_m: tuple[float, float] = (1.0, 2.5),
    z_m: tuple[float, float] = (0.0, 0.5),
    margin_px: float = 20.0,
    steps: tuple[int, int] = (31, 21),
    widths_x: tuple[float, ...] = (1.0, 1.5, 2.0, 2.5),
) -> RigCoverage:
    """Measure which targets (throw plane, floor to table height) the rig sees (see RigCoverage)."""
    xs, zs = np.linspace(*x_m, steps[0]), np.linspace(*z_m, steps[1])
    grid = np.array([[x, 0.0, z] for x in xs for z in zs])
    ok = in_common_view(cameras, grid, margin_px)
    missed = [(float(x), float(z)) for (x, _, z), o in zip(grid, ok) if not o]
    widths = []
    ys = np.linspace(-2.0, 2.0, 801)
    for x in widths_x:
        half = np.inf
        for z in z_m:
            seen = in_common_view(cameras, np.column_stack([np.full_like(ys, x), ys, np.full_like(ys, z)]), margin_px)
            half = min(half, float(min(-ys[seen].min(), ys[seen].max()))) if seen.any() else np.nan
        widths.append(half)
    return RigCoverage(x_m, z_m, margin_px, float(ok.mean()), missed, tuple(widths_x), tuple(widths))
