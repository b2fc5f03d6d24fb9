"""Leave-one-out cross-validation of a multi-camera calibration (the paper's Fig. 4).

For every calibration point i: calibrate each camera on all the other points it saw, triangulate
point i from its pixels with those cameras, and compare with its known position:

    e_i = || triangulate({P_c^(-i)}, {x_ci}) - X_i ||

The mean of e_i estimates the 3D error the calibration will make on new points in the same volume;
it is the error the paper plots against the number of calibration points.

`leave_one_out` does not refit n times: each camera is fitted once and its fits without each
point follow in closed form (`wiithrow.vision.dlt_loo`: exact for the linear methods, one
Gauss-Newton step for the refined and robust ones), and the n held-out points are triangulated
in one compiled pass (`kernels.triangulate_each`): O(n) time and memory, 100,000 points in
seconds (`wiithrow bench calibration`). `leave_one_out_brute_force` is the definition, refitting
every camera for every point (O(n^2)): the reference the tests hold the fast one to.

A point is tested when at least two cameras saw it and every camera that saw it can be fitted
without it, which needs MIN_POINTS + 1 = 7 points per camera; `LeaveOneOut.reason` says why
nothing could be tested.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import NamedTuple

import numpy as np
from numpy.typing import ArrayLike, NDArray

from wiithrow.vision import kernels
from wiithrow.vision.dlt import CalibratedCamera, Method, calibrate
from wiithrow.vision.dlt_loo import without_each
from wiithrow.vision.dlt_solvers import MIN_POINTS
from wiithrow.vision.errors import CalibrationError
from wiithrow.vision.triangulation import triangulate


class LeaveOneOut(NamedTuple):
    """Per-point held-out 3D errors (N,), NaN where a point could not be tested (seen by fewer than
    two cameras, or a camera could not be calibrated without it); `reason` says why no point
    could be tested ('' when some were)."""

    errors: NDArray[np.float64]
    reason: str = ""

    @property
    def mean(self) -> float:
        """Mean absolute 3D error over the tested points (NaN if none)."""
        finite = self.errors[np.isfinite(self.errors)]
        return float(finite.mean()) if finite.size else float("nan")

    @property
    def tested(self) -> int:
        """How many points were tested."""
        return int(np.isfinite(self.errors).sum())

    def worst(self, count: int = 5) -> NDArray[np.int64]:
        """Indices of the `count` points with the largest held-out error, worst first."""
        order = np.argsort(np.where(np.isfinite(self.errors), -self.errors, np.inf))
        return order[: min(count, self.tested)]


def _check(world: ArrayLike, image: ArrayLike) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    X = np.asarray(world, dtype=float)
    x = np.asarray(image, dtype=float)
    if x.ndim != 3 or x.shape[1] != X.shape[0] or x.shape[2] != 2 or X.ndim != 2 or X.shape[1] != 3:
        raise CalibrationError(f"leave-one-out needs world (N, 3) and image (C, N, 2); got {X.shape} and {x.shape}")
    return X, x


def leave_one_out(
    world: ArrayLike,
    image: ArrayLike,
    method: Method = "refined",
    *,
    cameras: Sequence[CalibratedCamera | None] | None = None,
) -> LeaveOneOut:
    """Held-out 3D error of every point of a calibration set (module docstring).

    Args:
        world: (N, 3) known points (m).
        image: (C, N, 2) their pixels in C >= 2 cameras, NaN where unseen.
        method: the calibration method each fold refits with (`calibrate`).
        cameras: each camera already fitted by `method` to the points it saw, in order (as
            `calibrate_rig` has them; None: fitted here).

    Returns:
        A `LeaveOneOut`: each point's 3D error (m) when its cameras' fits leave it out (NaN where it
        could not be tested), and their mean.
    """
    X, x = _check(world, image)
    n, C = X.shape[0], x.shape[0]
    seen = np.asarray(np.isfinite(x).all(axis=2), dtype=bool)
    folds = np.full((n, C, 3, 4), np.nan)
    problems = []
    for c in range(C):
        idx = np.flatnonzero(seen[c])
        if idx.size < MIN_POINTS + 1:
            problems.append(f"cam{c} saw {idx.size}")
            continue
        camera = cameras[c] if cameras is not None else None
        try:
            if camera is None:
                camera = calibrate(X[idx], x[c, idx], method, name=f"cam{c}")
        except CalibrationError as exc:
            problems.append(f"cam{c} cannot be calibrated ({exc})")
            continue
        folds[idx, c] = without_each(method, camera)
    scale = np.linalg.norm(folds[:, :, 2, :3], axis=2)
    folds /= np.where(scale > 0, scale, np.nan)[:, :, None, None]
    estimates = np.empty((n, 3))
    views = np.empty(n, dtype=np.int64)
    kernels.triangulate_each(np.ascontiguousarray(folds), np.ascontiguousarray(x), estimates, views)
    tested = (seen.sum(axis=0) >= 2) & (views == seen.sum(axis=0))
    errors = np.where(tested, np.linalg.norm(estimates - X, axis=1), np.nan)
    return LeaveOneOut(errors, "" if np.isfinite(errors).any() else _reason(problems, seen))


def _reason(problems: list[str], seen: NDArray[np.bool_]) -> str:
    """Why no point could be tested."""
    if not (seen.sum(axis=0) >= 2).any():
        return "leave-one-out needs points seen by at least two cameras, and no point was"
    if problems:
        return (
            f"leave-one-out needs at least {MIN_POINTS + 1} points per camera ({MIN_POINTS} to fit it "
            f"without the point left out): {', '.join(problems)}"
        )
    return "no camera could be fitted without any of the points"


def leave_one_out_brute_force(world: ArrayLike, image: ArrayLike, method: Method = "refined") -> LeaveOneOut:
    """The definition, by refitting every camera without every point: O(N^2) (module docstring)."""
    X, x = _check(world, image)
    n = X.shape[0]
    seen = np.asarray(np.isfinite(x).all(axis=2), dtype=bool)
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
        estimate = triangulate(np.array(Ps), x[cams, i : i + 1]).points[0]
        errors[i] = np.linalg.norm(estimate - X[i])
    return LeaveOneOut(errors)
