"""Choosing the calibration poses from the candidates: the optimal design, or a random one.

`select_poses`: `"optimal"` adds, one at a time, the candidate whose point lowers the criterion Phi
(`wiithrow.app.calibration.poses.error_model`) most (a rank-2 update per camera: the gain of point
i is tr((sigma^2 I + J Sigma J^T)^-1 J Sigma H Sigma J^T) summed over cameras), keeping every new
point `min_separation` away from the chosen ones so the design also fills the space; `"random"`
draws candidates uniformly (the baseline). Both are ordered for short moves (`travel_order`).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray

from wiithrow.app.calibration.poses.candidates import PoseCandidates, sample_candidates
from wiithrow.app.calibration.poses.error_model import ErrorModel, frame_sigma_px, parameter_jacobians
from wiithrow.app.errors import AppError
from wiithrow.robot import ArmModel
from wiithrow.vision.camera import WiimoteCamera

Design = Literal["optimal", "random"]
DESIGNS: tuple[Design, ...] = ("optimal", "random")


def greedy_optimal(
    model: ErrorModel, candidates: NDArray[np.float64], n: int, *, min_separation_m: float = 0.0
) -> NDArray[np.int64]:
    """Indices of `n` candidates chosen greedily to minimise Phi (see the module docstring)."""
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
    if candidates is not None:
        cand = candidates
    else:
        assert arm is not None  # checked above
        cand = sample_candidates(arm, cameras, rng, **candidate_options)
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
