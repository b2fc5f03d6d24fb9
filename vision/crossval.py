"""Leave-one-out cross-validation of a multi-camera calibration (the paper's Fig. 4).

For every calibration point i: calibrate each camera on all the other points it saw, triangulate
point i from its pixels with those cameras, and compare with its known position:

    e_i = || triangulate({P_c^(-i)}, {x_ci}) - X_i ||

The mean of e_i estimates the 3D error the calibration will make on new points in the same volume;
it is the error the paper plots against the number of calibration points.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numpy.typing import ArrayLike, NDArray

from wiithrow.vision.dlt import Method, calibrate
from wiithrow.vision.errors import CalibrationError
from wiithrow.vision.triangulate import triangulate


class LeaveOneOut(NamedTuple):
    """Per-point held-out 3D errors (N,), NaN where a point could not be tested (seen by fewer than
    two cameras, or a camera could not be calibrated without it)."""

    errors: NDArray[np.float64]

    @property
    def mean(self) -> float:
        """Mean absolute 3D error over the tested points (NaN if none)."""
        finite = self.errors[np.isfinite(self.errors)]
        return float(finite.mean()) if finite.size else float("nan")

    def worst(self, count: int = 5) -> NDArray[np.int64]:
        """Indices of the `count` points with the largest held-out error, worst first."""
        order = np.argsort(np.where(np.isfinite(self.errors), -self.errors, np.inf))
        return order[: min(count, int(np.isfinite(self.errors).sum()))]


def leave_one_out(
    world: ArrayLike,
    image: ArrayLike,
    method: Method = "refined",
    *,
    refine_triangulation: bool = False,
) -> LeaveOneOut:
    """Held-out 3D error of every point of a calibration set.

    world: (N, 3) known points; image: (C, N, 2) their pixels in C >= 2 cameras, NaN where unseen.
    """
    X = np.asarray(world, dtype=float)
    x = np.asarray(image, dtype=float)
    if x.ndim != 3 or x.shape[1] != X.shape[0] or x.shape[2] != 2 or X.ndim != 2 or X.shape[1] != 3:
        raise CalibrationError(f"leave-one-out needs world (N, 3) and image (C, N, 2); got {X.shape} and {x.shape}")
    n = X.shape[0]
    seen = np.isfinite(x).all(axis=2)
    errors = np.full(n, np.nan)
    for i in range(n):
        cams = np.flatnonzero(seen[:, i])
        if cams.size < 2:
            continue
        Ps = []
        for c in cams:
            train = seen[c].copy()
            train[i] = False
            try:
                Ps.append(calibrate(X[train], x[c, train], method).P)
            except CalibrationError:
                Ps = []
                break
        if len(Ps) < 2:
            continue
        estimate = triangulate(np.array(Ps), x[cams, i : i + 1], refine=refine_triangulation).points[0]
        errors[i] = np.linalg.norm(estimate - X[i])
    return LeaveOneOut(errors)
