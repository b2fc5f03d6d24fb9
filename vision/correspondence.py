"""Which dot in one camera is which dot in another: correspondence of up to 4 dots per camera.

Each camera reports up to four anonymous dots. A 3D marker is a set of dots, at most one per
camera, that are images of one point. Two sources of evidence decide the sets:

* Epipolar geometry. For cameras a and b with projection matrices P_a, P_b the fundamental matrix

      F_ab = [e_b]x P_b P_a^+        (e_b = P_b C_a, C_a the null vector of P_a)

  maps a dot x_a to its epipolar line l = F_ab x_a in b; a true partner x_b lies on it. The cost of
  pairing is the symmetric point-to-line distance in pixels,

      d(x_a, x_b) = ( |x_b^T F x_a| / ||(F x_a)_1:2|| + |x_a^T F^T x_b| / ||(F^T x_b)_1:2|| ) / 2.

* Prediction. When the tracker knows where its markers should be, their projections tell which dot
  is which in every camera directly, which also resolves the ghosts that epipolar geometry alone
  cannot (two markers on one epipolar line pair either way).

The algorithm: (1) with predictions, each camera's dots are assigned to the predicted markers'
projections by minimum-cost assignment (scipy's `linear_sum_assignment`), gated in pixels; a marker
with dots in two or more cameras is triangulated and kept if its reprojection error passes the gate.
(2) The dots left over are matched camera pair by camera pair by minimum-cost assignment on the
epipolar cost, gated; every further camera's leftover dots join a new marker when its reprojection
lands within the gate. A dot seen by one camera only stays unmatched rather than being forced into a
wrong pair; unmatched is always allowed (each row and column of the cost matrix has a "no partner"
option at the gate's cost).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.optimize import linear_sum_assignment

from wiithrow.vision import kernels
from wiithrow.vision.errors import TriangulationError
from wiithrow.vision.geometry import homogeneous, skew

#: Default gate (pixels) for epipolar distance and reprojection error of a match.
DEFAULT_GATE_PX = 4.0
#: Default gate (pixels) between a dot and a predicted marker's projection.
DEFAULT_PREDICTION_GATE_PX = 12.0


#: Accepted markers collected while matching, in groups: (slots (M, C), points (M, 3), RMS
#: reprojection errors (M,), the prediction each was matched to (M,), -1 for none).
Found = list[tuple[NDArray[np.int64], NDArray[np.float64], NDArray[np.float64], NDArray[np.int64]]]


@dataclass(frozen=True)
class Markers:
    """3D markers found in one set of camera frames.

    points: (M, 3) triangulated positions; slots: (M, C) index of the dot used in each camera
    (-1 where the camera does not contribute); reprojection_px: (M,) RMS over contributing cameras;
    predicted_index: (M,) the prediction each marker was matched to (-1 for new ones);
    unmatched: (C, K) True where a visible dot was not used.
    """

    points: NDArray[np.float64]
    slots: NDArray[np.int64]
    reprojection_px: NDArray[np.float64]
    predicted_index: NDArray[np.int64]
    unmatched: NDArray[np.bool_]


def fundamental_matrix(Pa: NDArray[np.float64], Pb: NDArray[np.float64]) -> NDArray[np.float64]:
    """F with x_b^T F x_a = 0 for the images x_a, x_b of one point (HZ eq. 9.1)."""
    _, _, Vt = np.linalg.svd(Pa)
    Ca = Vt[-1]
    eb = Pb @ Ca
    F = skew(eb) @ Pb @ np.linalg.pinv(Pa)
    normalized: NDArray[np.float64] = F / np.linalg.norm(F)
    return normalized


def epipolar_cost(F: NDArray[np.float64], xa: NDArray[np.float64], xb: NDArray[np.float64]) -> NDArray[np.float64]:
    """Symmetric point-to-epipolar-line distance (pixels) for all pairs: (Ka, Kb); NaN dots give inf."""
    ha = homogeneous(xa)
    hb = homogeneous(xb)
    lines_b = ha @ F.T  # (Ka, 3): epipolar lines in b of the dots of a
    lines_a = hb @ F  # (Kb, 3): epipolar lines in a of the dots of b
    algebraic = np.abs(ha @ F.T @ hb.T)  # |x_b^T F x_a| as (Ka, Kb)
    with np.errstate(divide="ignore", invalid="ignore"):
        d = 0.5 * (
            algebraic / np.linalg.norm(lines_b[:, :2], axis=1)[:, None]
            + algebraic / np.linalg.norm(lines_a[:, :2], axis=1)[None, :]
        )
    return np.where(np.isfinite(d), d, np.inf)


def gated_assignment(cost: ArrayLike, gate: float) -> list[tuple[int, int]]:
    """Minimum-cost assignment in which any row or column may stay unassigned at cost `gate`.

    The cost matrix is padded to (R + C) x (C + R): real pairs, "row unassigned" and "column
    unassigned" options at cost `gate`, so a pair is chosen only if it beats leaving both alone.
    (The per-frame path tries an exact shortcut first: `kernels.assign_to_predictions`.)
    """
    cost = np.asarray(cost, dtype=float)
    rows, cols = cost.shape
    if rows == 0 or cols == 0:
        return []
    big = 1e9
    padded = np.full((rows + cols, cols + rows), big)
    padded[:rows, :cols] = np.where(cost < gate, cost, big)
    padded[:rows, cols:] = np.where(np.eye(rows, dtype=bool), gate, big)
    padded[rows:, :cols] = np.where(np.eye(cols, dtype=bool), gate, big)
    padded[rows:, cols:] = 0.0
    r, c = linear_sum_assignment(padded)
    return [(int(i), int(j)) for i, j in zip(r, c) if i < rows and j < cols and padded[i, j] < big]


class Correspondence:
    """Matches the dots of C >= 2 calibrated cameras into 3D markers (see the module docstring).

    Construct once per calibration (the fundamental matrices are computed here), then call
    `match` for every set of frames. The per-frame work runs in compiled kernels
    (`wiithrow.vision.kernels`): a frame holds a handful of dots, where numpy's per-call cost would dominate.
    """

    def __init__(
        self,
        Ps: ArrayLike,
        *,
        gate_px: float = DEFAULT_GATE_PX,
        prediction_gate_px: float = DEFAULT_PREDICTION_GATE_PX,
    ) -> None:
        P = np.asarray(Ps, dtype=float)
        if P.ndim != 3 or P.shape[0] < 2 or P.shape[1:] != (3, 4) or not np.isfinite(P).all():
            raise TriangulationError(f"correspondence needs finite (C >= 2, 3, 4) projection matrices, got {P.shape}")
        self.Ps = np.ascontiguousarray(P / np.linalg.norm(P[:, 2, :3], axis=1)[:, None, None])
        self.gate_px = gate_px
        self.prediction_gate_px = prediction_gate_px
        C = P.shape[0]
        self.F = {(a, b): fundamental_matrix(self.Ps[a], self.Ps[b]) for a in range(C) for b in range(C) if a < b}

    @property
    def cameras(self) -> int:
        return int(self.Ps.shape[0])

    def match(self, dots: ArrayLike, predicted: ArrayLike | None = None) -> Markers:
        """Markers from dots (C, K, 2) (NaN where a slot is empty), optionally guided by
        `predicted` (M, 3) marker positions."""
        x = np.ascontiguousarray(dots, dtype=float)
        if x.ndim != 3 or x.shape[0] != self.cameras or x.shape[2] != 2:
            raise TriangulationError(f"dots must have shape ({self.cameras}, K, 2), got {x.shape}")
        C, K = x.shape[0], x.shape[1]
        pred = np.ascontiguousarray(predicted if predicted is not None else np.zeros((0, 3)), dtype=float).reshape(
            -1, 3
        )
        free = np.empty((C, K), dtype=np.bool_)  # visible dots not yet used
        slots = np.empty((len(pred), C), dtype=np.int64)
        points = np.empty((len(pred), 3))
        rms = np.empty(len(pred))
        origins = np.empty(len(pred), dtype=np.int64)
        n = kernels.match_predicted(
            self.Ps, x, pred, self.prediction_gate_px, self.gate_px, free, slots, points, rms, origins
        )
        found: Found = []
        if n > 0:
            found.append((slots[:n], points[:n], rms[:n], origins[:n]))
        elif n < 0:  # a camera's nearest dots conflict: the full minimum-cost assignment
            self._match_predicted(x, free, pred, found)
        if free.any(axis=1).sum() >= 2:
            self._match_epipolar(x, free, found)
        return self._markers(free, found)

    def match_remaining(self, dots: NDArray[np.float64], free: NDArray[np.bool_]) -> Markers:
        """Markers from the dots still marked `free` (C, K) by epipolar matching only (the dots
        matched through predictions are already taken). `free` is updated."""
        found: Found = []
        if free.any(axis=1).sum() >= 2:
            self._match_epipolar(dots, free, found)
        return self._markers(free, found)

    # -- step 1: predictions -------------------------------------------------------------------

    def _match_predicted(
        self, x: NDArray[np.float64], free: NDArray[np.bool_], predicted: NDArray[np.float64], found: Found
    ) -> None:
        """Assign each camera's dots to the predicted markers' projections by minimum-cost
        assignment (gated), then validate the candidates."""
        M = predicted.shape[0]
        expected = np.empty((self.cameras, M, 2))
        kernels.project(self.Ps, predicted, expected)
        slots = np.full((M, self.cameras), -1, dtype=np.int64)
        for c in range(self.cameras):
            cost = np.linalg.norm(expected[c][:, None, :] - x[c][None, :, :], axis=2)
            cost[:, ~free[c]] = np.inf
            for m, k in gated_assignment(np.where(np.isfinite(cost), cost, np.inf), self.prediction_gate_px):
                slots[m, c] = k
        candidates = (slots >= 0).sum(axis=1) >= 2
        self._accept(x, free, slots[candidates], np.flatnonzero(candidates), found)

    def _accept(
        self,
        x: NDArray[np.float64],
        free: NDArray[np.bool_],
        slots: NDArray[np.int64],
        origins: NDArray[np.int64],
        found: Found,
    ) -> None:
        """Keep the candidates (rows of `slots`) that reproject within the gate (see
        `kernels.accept_candidates`) and use dots not yet taken; mark their dots used."""
        if len(slots) == 0:
            return
        slots = np.ascontiguousarray(slots, dtype=np.int64)
        points = np.empty((len(slots), 3))
        rms = np.empty(len(slots))
        accepted = kernels.accept_candidates(self.Ps, x, slots, self.gate_px, free, points, rms)
        if accepted.any():
            found.append((slots[accepted], points[accepted], rms[accepted], np.asarray(origins)[accepted]))

    # -- step 2: epipolar matching of what is left ---------------------------------------------

    def _match_epipolar(self, x: NDArray[np.float64], free: NDArray[np.bool_], found: Found) -> None:
        """Two cameras: minimum-cost assignment on the epipolar cost, gated. More cameras: every
        gated pair of every camera pair is a candidate, extended with the other cameras' dots near
        its reprojection; candidates seen by more cameras (then with lower error) win, so a ghost
        that only two cameras agree on loses to the real marker the others confirm."""
        C = self.cameras
        candidates = []
        for a in range(C):
            for b in range(a + 1, C):
                ka, kb = np.flatnonzero(free[a]), np.flatnonzero(free[b])
                if ka.size == 0 or kb.size == 0:
                    continue
                cost = epipolar_cost(self.F[(a, b)], x[a, ka], x[b, kb])
                pairs = gated_assignment(cost, self.gate_px) if C == 2 else zip(*np.nonzero(cost < self.gate_px))
                for i, j in pairs:
                    group = np.full(C, -1, dtype=np.int64)
                    group[a], group[b] = ka[i], kb[j]
                    self._extend(x, free, group, a, b)
                    candidates.append(group)
        if not candidates:
            return
        slots = np.unique(np.array(candidates), axis=0)
        points = np.empty((len(slots), 3))
        errors = np.empty(slots.shape)
        kernels.triangulate_groups(self.Ps, x, slots, points, errors)
        views = (slots >= 0).sum(axis=1)
        rms = np.sqrt(np.where(errors >= 0, errors**2, 0.0).sum(axis=1) / views)
        order = np.lexsort((np.nan_to_num(rms, nan=np.inf), -views))
        self._accept(x, free, slots[order], np.full(len(slots), -1), found)

    def _extend(
        self, x: NDArray[np.float64], free: NDArray[np.bool_], group: NDArray[np.int64], a: int, b: int
    ) -> None:
        """Add the other cameras' free dots that lie within the gate of the pair's 3D point."""
        if self.cameras == 2:
            return
        point = np.empty((1, 3))
        errors = np.empty((1, self.cameras))
        kernels.triangulate_groups(self.Ps, x, group[None], point, errors)
        if not np.isfinite(point).all():
            return
        expected = np.empty((self.cameras, 1, 2))
        kernels.project(self.Ps, point, expected)
        for c in range(self.cameras):
            k_free = np.flatnonzero(free[c])
            if c in (a, b) or k_free.size == 0:
                continue
            d = np.linalg.norm(x[c, k_free] - expected[c, 0], axis=1)
            if d.min() <= self.gate_px:
                group[c] = k_free[int(np.argmin(d))]

    # -- results --------------------------------------------------------------------------------

    def _markers(self, free: NDArray[np.bool_], found: Found) -> Markers:
        if not found:
            C = self.cameras
            return Markers(
                np.zeros((0, 3)), np.zeros((0, C), dtype=np.int64), np.zeros(0), np.zeros(0, dtype=np.int64), free
            )
        if len(found) == 1:
            slots, points, rms, origins = found[0]
        else:
            slots, points, rms, origins = (np.concatenate(parts) for parts in zip(*found))
        return Markers(points, slots, rms, origins.astype(np.int64), free)
