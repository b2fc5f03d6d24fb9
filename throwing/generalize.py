"""Generalization: a new target (x, z) in link1 -> throw parameters, by regression over the library.

As in Ude, Gams, Asfour, Morimoto (2010), the parameters of a movement are regressed on the task
query, here the landing point: Gaussian process regression (`wiithrow.throwing.gp`: ARD RBF kernel + noise,
linear mean, standardized inputs, hyperparameters by maximum marginal likelihood), inputs the
measured landings (x, z) of the 25 trained throws, outputs their parameter vectors
theta = (q_r, dq_r). Regressing on the *measured* landing is what lets the learning absorb
systematic errors of execution and measurement in the throw plane; how far beside it the throws
land (their across labels) is fitted beside the regression (`wiithrow.throwing.lateral`, `across`).

Only targets in the trained area are served: the convex hull of the measured landings, optionally
grown by a stated margin (m); outside it a regression extrapolates and is refused with
`OutsideTrainedAreaError`.

Two held-out figures, both leaving each trained throw out in turn (fit on the other N - 1,
hyperparameters refitted from those of the fit to all N) and predicting the parameters for its
measured landing:

* `leave_one_out_error`, the model mismatch: fly the predicted throw by the planner's model (noise
  free, with drag) to the landing's height and take the distance to the label. It adds the
  regression's error to how far the model's flight is from the world's (a throw the model flies to
  x may land at x + 5 cm in the world, and the label says where it landed): large in a world whose
  physics the model does not know, even for a perfect regression. It is not the library's quality.
* `regression_leave_one_out_error`, the regression's own held-out error (the paper's leave-one-out):
  fly both the predicted and the trained throw by the same model and take the distance between
  their landings. The model's mismatch cancels (to first order): what is left is how far the
  regression's answer for an unseen landing is from the throw that produced it, in landing terms.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.spatial import ConvexHull, QhullError

from wiithrow.robot import ArmModel, load_arm
from wiithrow.throwing.ballistics import Ball
from wiithrow.throwing.errors import NoLandingError, OutsideTrainedAreaError, ThrowingError
from wiithrow.throwing.forward import predict_landing
from wiithrow.throwing.gp import GaussianProcess, GPHyperparameters
from wiithrow.throwing.lateral import LateralTerm
from wiithrow.throwing.library import ThrowLibrary
from wiithrow.throwing.representation import ThrowParameters
from wiithrow.throwing.throw_plane import xz


class TrainedArea:
    """The convex hull of points (x, z) in link1 (m); `distance_outside(p)` is 0 inside."""

    def __init__(self, points: ArrayLike) -> None:
        P = np.asarray(points, dtype=float)
        if P.ndim != 2 or P.shape[1] != 2 or P.shape[0] < 3:
            raise ThrowingError(f"a trained area needs at least 3 points (x, z), got shape {P.shape}")
        try:
            hull = ConvexHull(P)
        except QhullError as exc:
            raise ThrowingError(f"the trained landings span no area (collinear?): {str(exc).splitlines()[0]}") from None
        self.vertices = P[hull.vertices]  # counter-clockwise
        self.equations = hull.equations  # a x + b z + c <= 0 inside, (a, b) unit normals
        self.n_points = P.shape[0]

    @property
    def bounds(self) -> tuple[tuple[float, float], tuple[float, float]]:
        """((x_min, x_max), (z_min, z_max)) of the hull (m)."""
        lo, hi = self.vertices.min(axis=0), self.vertices.max(axis=0)
        return (float(lo[0]), float(hi[0])), (float(lo[1]), float(hi[1]))

    def describe(self) -> str:
        (x0, x1), (z0, z1) = self.bounds
        return (
            f"the convex hull of the {self.n_points} measured landings, within x {x0:.3f}-{x1:.3f} m, "
            f"z {z0:.3f}-{z1:.3f} m in link1"
        )

    def distance_outside(self, p: ArrayLike) -> float:
        """Euclidean distance (m) from p (x, z) to the hull; 0 inside or on it."""
        p = xz(p)
        if np.all(self.equations[:, :2] @ p + self.equations[:, 2] <= 1e-12):
            return 0.0
        a = self.vertices
        b = np.roll(a, -1, axis=0)
        ab = b - a
        s = np.clip(np.einsum("ij,ij->i", p - a, ab) / np.einsum("ij,ij->i", ab, ab), 0.0, 1.0)
        return float(np.min(np.linalg.norm(a + s[:, None] * ab - p, axis=1)))

    def contains(self, p: ArrayLike, margin: float = 0.0) -> bool:
        """True if p is inside the hull grown by `margin` (m)."""
        return self.distance_outside(p) <= margin

    def check(self, p: ArrayLike, margin: float = 0.0) -> None:
        """Raise OutsideTrainedAreaError unless p is within `margin` (m) of the hull."""
        d = self.distance_outside(p)
        if d > margin:
            x, z = xz(p)
            raise OutsideTrainedAreaError(
                f"target ({x:.3f}, {z:.3f}) m in link1 is {d:.3f} m outside the trained area ({self.describe()}); "
                f"choose a target inside it{f' or within the allowed margin of {margin:.3f} m' if margin > 0 else ''}, "
                "or allow a margin (metres) to extrapolate",
                (x, z),
                d,
                margin,
            )


class Generalizer:
    """Throw parameters for new targets by GP regression over a library (module docstring)."""

    def __init__(self, library: ThrowLibrary, *, initial: list[GPHyperparameters] | None = None) -> None:
        if len(library) < 4:
            raise ThrowingError(f"generalization needs at least 4 trained throws, the library has {len(library)}")
        self.library = library
        self.area = TrainedArea(library.landings)
        self.gp = GaussianProcess().fit(library.landings, library.parameters, initial)
        self.lateral = LateralTerm.fit(library.landings, library.across)

    def across(self, target: ArrayLike) -> float:
        """The across offset (m) a throw served for `target` (x, z) lands beside its plane
        (`lateral.LateralTerm`, fitted to the throws' across labels; 0 for a library without them)."""
        return self.lateral.across(xz(target))

    def predict(self, target: ArrayLike) -> ThrowParameters:
        """Parameters for `target` (x, z) in link1, without the area check."""
        return ThrowParameters.from_vector(self.gp.predict(xz(target)[None, :])[0])

    def params_for(self, target: ArrayLike, margin: float = 0.0) -> ThrowParameters:
        """Parameters for `target` (x, z) in link1; OutsideTrainedAreaError if it lies more than
        `margin` (m) outside the trained area."""
        if not margin >= 0:
            raise ThrowingError(f"margin must be >= 0 m, got {margin}")
        self.area.check(target, margin)
        return self.predict(target)


@dataclass(frozen=True)
class LeaveOneOutResult:
    """Leave-one-out landing errors (m), one per trained throw, and their summary."""

    errors: NDArray[np.float64]

    @property
    def mean(self) -> float:
        return float(np.mean(self.errors))

    @property
    def median(self) -> float:
        return float(np.median(self.errors))

    @property
    def rms(self) -> float:
        return float(np.sqrt(np.mean(self.errors**2)))

    @property
    def max(self) -> float:
        return float(np.max(self.errors))

    def __str__(self) -> str:
        return (
            f"leave-one-out landing error over {self.errors.size} throws: mean {1e3 * self.mean:.1f} mm, "
            f"median {1e3 * self.median:.1f} mm, rms {1e3 * self.rms:.1f} mm, max {1e3 * self.max:.1f} mm"
        )


def leave_one_out_error(
    library: ThrowLibrary, arm: ArmModel | None = None, *, ball: Ball | None = None
) -> LeaveOneOutResult:
    """Leave-one-out landing error (module docstring). `arm` defaults to `load_arm(library.arm)`;
    `ball` to the library's. The flight is noise-free, with drag; a throw that never reaches the
    label's height counts as an infinite error."""
    arm = arm or load_arm(library.arm)
    ball = ball or library.ball
    errors = np.empty(len(library))
    full = Generalizer(library).gp.hyper  # each fold refits, starting from the full fit's hyperparameters
    for i, thr in enumerate(library.throws):
        gen = Generalizer(library.without(i), initial=full)
        params = gen.predict(thr.landing)
        try:
            land = predict_landing(arm, library.shape, params, float(thr.landing[1]), 0.0, ball)
            errors[i] = float(np.hypot(land.link1[0] - thr.landing[0], land.link1[1]))
        except NoLandingError:
            errors[i] = np.inf
    return LeaveOneOutResult(errors)


def regression_leave_one_out_error(
    library: ThrowLibrary, arm: ArmModel | None = None, *, ball: Ball | None = None
) -> LeaveOneOutResult:
    """The regression's own held-out error (module docstring): for each trained throw, the distance
    between the model's landings of the parameters predicted without it and of its own parameters.
    `arm`, `ball` as `leave_one_out_error`; a throw that never reaches the height is infinite."""
    arm = arm or load_arm(library.arm)
    ball = ball or library.ball
    errors = np.empty(len(library))
    full = Generalizer(library).gp.hyper
    for i, thr in enumerate(library.throws):
        params = Generalizer(library.without(i), initial=full).predict(thr.landing)
        height = float(thr.landing[1])
        try:
            predicted = predict_landing(arm, library.shape, params, height, 0.0, ball).link1
            trained = predict_landing(arm, library.shape, thr.params, height, 0.0, ball).link1
            errors[i] = float(np.hypot(predicted[0] - trained[0], predicted[1] - trained[1]))
        except NoLandingError:
            errors[i] = np.inf
    return LeaveOneOutResult(errors)
