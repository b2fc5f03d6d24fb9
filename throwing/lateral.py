"""The sideways miss of a library's throws, learned, and the joint-1 angle that aims it away.

A throw is planned in its plane (link1 at its joint-1 angle q1), and the model flies the ball in
it. A ball held off-centre in the hand, fingers that push it sideways as they open, a joint-1 zero
that is off put it down beside the plane instead, by the throw's *across offset* a (m, y of link1
at the throw's q1, + toward +y). The regression learns the along part of a miss (the measured
landing labels the throw's parameters), but a throw's parameters move the ball in its plane only:
the across part is learned here, as a function of where in the plane the throw lands,

    a(x, z) = w . h(x, z),      h(x, z) = (1, (x - x0) / sx, (z - z0) / sz),

linear: a steady offset (w_0), a part that grows with the distance (an angle: w_1) and one that
changes with the height (w_2); (x0, z0) and (sx, sz) are the mean and spread of the library's
landings when the term was made, fixed from then on so that w keeps its meaning.

**Fit** (`LateralTerm.fit`): Bayesian linear regression of the throws' across labels y_i (the
rig's measurement, `library.TrainedThrow.across`; a throw without one says nothing), prior
w ~ N(0, P0) with P0 = diag(PRIOR_M)^2, label noise N(0, NOISE_M^2):

    P = (P0^-1 + H^T H / NOISE_M^2)^-1,     w = P H^T y / NOISE_M^2.

A library without labels (a file from before they were kept) has w = 0 and P = P0: no
correction, and the first measured throws say what it is.

**Learning** (`update`, once per measured throw that joins the library): a Kalman filter step on
w, after a random walk of the coefficients by WALK_M per throw (w may change between throws, as
the regression's drift term may: a hand that starts to push the ball sideways is followed, old
labels are not believed for ever):

    P <- P + diag(WALK_M)^2
    nu = y - w . h,   s = h P h^T + r^2,   k = P h / s
    w <- w + k nu,    P <- P - k h^T P

with r = NOISE_M, except where that step would move a(x, z) by more than STEP_BOUND_M at any
point of `within` (the trained area's corners; a is linear, so its largest move over the area is
at a corner) or at the throw's own landing: then r^2 is raised until the largest move is the bound
(a Huber-like robust step: the label is believed less, never dropped), so that one throw moves the
correction by at most STEP_BOUND_M, whatever it measured. Whether a throw may join at all (its
ball left the hand at the release, its landing was seen and is credible) is the library's and the
session's rule, the same as for the along part: what joins the regression updates this term.

**The aim** (`aim`): a target at distance d from joint 1's axis and azimuth psi in base is hit by
the throw that lands at (x, a) in its plane with x^2 + a^2 = d^2, its plane turned so that the
landing's azimuth is psi:

    x = sqrt(d^2 - a^2),     q1 = psi - atan2(a, x),

a = a(d, z) (taking a at x = d rather than at x moves it by (d - x) w_1 / sx, far below a
micrometre for a few centimetres of offset).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from wiithrow.throwing.errors import LibraryFormatError, ThrowingError

#: The prior's standard deviation of (w_0, w_1, w_2), m: a steady sideways miss of up to a few
#: centimetres (the first labels move w_0 by most of what they measure, up to STEP_BOUND_M), and a
#: change of a few millimetres over one spread of the landings (a joint-1 zero off by 10 mrad
#: makes 2 mm per 0.2 m of distance), so that one throw at a corner is read as an offset first.
PRIOR_M = (0.02, 0.005, 0.005)
#: One throw's across label about the term (m): the rig's measurement (about 1 mm), joint 1's
#: tracking (1 mrad, 1.5 mm at 1.5 m), the marker put where the ball came down (the MuJoCo world's
#: operator: 5 mm per direction).
NOISE_M = 0.004
#: How far (m) the coefficients may wander per throw that joins (the random walk): a library whose
#: labels said "no sideways miss" follows a new steady one with a gain of about 0.2 per throw.
WALK_M = (0.001, 0.00025, 0.00025)
#: The most (m) one throw's update moves the correction anywhere in the trained area.
STEP_BOUND_M = 0.010
#: The least spread (m) of the landings the inputs are scaled by (a library whose throws share a
#: distance or a height).
MIN_SPREAD_M = 0.05


@dataclass(frozen=True)
class Aim:
    """Where a throw is planned for a target (`LateralTerm.aim`, `planner.ThrowPlanner.aim`):
    `xz` the landing (x, z) in the throw's plane (m), `q1` joint 1's angle (rad), `across_m` the
    learned across offset a aimed away (m; 0 without a correction)."""

    xz: NDArray[np.float64]
    q1: float
    across_m: float


def aim_at(across_m: float, distance: float, height: float, azimuth: float) -> Aim:
    """The throw that lands `across_m` beside its plane hitting the target at `distance` (m from
    joint 1's axis), `height` (m) and `azimuth` (rad, base) (module docstring, "The aim").
    ThrowingError for a target no nearer than the offset."""
    if not (math.isfinite(across_m) and math.isfinite(distance) and math.isfinite(height) and math.isfinite(azimuth)):
        raise ThrowingError(f"a target to aim at must be finite, got d {distance}, z {height}, psi {azimuth}")
    if not distance > abs(across_m):
        raise ThrowingError(
            f"a target {distance:.3f} m from joint 1's axis is within the sideways offset {across_m:.3f} m"
        )
    x = math.sqrt(distance**2 - across_m**2)
    return Aim(np.array([x, float(height)]), float(azimuth - math.atan2(across_m, x)), float(across_m))


class LateralTerm:
    """The learned across offset of a library's throws (module docstring). Build it with `fit` or
    `from_dict`; `update` learns from one measured throw."""

    def __init__(self, origin: ArrayLike, spread: ArrayLike, w: ArrayLike, P: ArrayLike, updates: int = 0) -> None:
        self.origin = np.asarray(origin, dtype=float).reshape(2)
        self.spread = np.asarray(spread, dtype=float).reshape(2)
        self.w = np.asarray(w, dtype=float).reshape(3).copy()
        self.P = np.asarray(P, dtype=float).reshape(3, 3).copy()
        self.updates = int(updates)
        if not (np.isfinite(self.origin).all() and np.isfinite(self.w).all() and np.isfinite(self.P).all()):
            raise ThrowingError("a sideways term must be finite")
        if not (np.all(self.spread > 0) and np.all(np.diag(self.P) >= 0) and self.updates >= 0):
            raise ThrowingError("a sideways term needs positive spreads, a covariance and a count of updates >= 0")

    @classmethod
    def fit(cls, landings: ArrayLike, across: ArrayLike) -> LateralTerm:
        """The term fitted to throws landed at `landings` (N, 2) (x, z) with across labels `across`
        (N,) m, NaN where a throw has none (module docstring, "Fit")."""
        X = np.asarray(landings, dtype=float).reshape(-1, 2)
        y = np.asarray(across, dtype=float).reshape(-1)
        origin = X.mean(axis=0) if len(X) else np.zeros(2)
        spread = np.maximum(X.std(axis=0) if len(X) else np.zeros(2), MIN_SPREAD_M)
        term = cls(origin, spread, np.zeros(3), np.diag(np.square(PRIOR_M)))
        known = np.isfinite(y)
        if known.any():
            H = term._features(X[known])
            info = np.diag(1.0 / np.square(PRIOR_M)) + H.T @ H / NOISE_M**2
            term.P = np.linalg.inv(info)
            term.w = term.P @ H.T @ y[known] / NOISE_M**2
        return term

    def _features(self, X: ArrayLike) -> NDArray[np.float64]:
        Z = (np.atleast_2d(np.asarray(X, dtype=float)) - self.origin) / self.spread
        return np.column_stack([np.ones(len(Z)), Z])

    def across(self, target: ArrayLike) -> float:
        """The across offset a (m) of a throw landing at `target` (x, z) in its plane."""
        return float(self._features(target)[0] @ self.w)

    def aim(self, distance: float, height: float, azimuth: float) -> Aim:
        """The throw for a target at `distance` (m), `height` (m), `azimuth` (rad, base), its learned
        offset aimed away (`aim_at`)."""
        return aim_at(self.across((distance, height)), distance, height, azimuth)

    def update(self, landing: ArrayLike, across: float, within: ArrayLike) -> float:
        """Learn from one throw that landed at `landing` (x, z) `across` m beside its plane; `within`
        (M, 2): the trained area's corners (module docstring, "Learning"). Returns the largest move
        (m) of the correction over `within` and the landing."""
        y = float(across)
        if not math.isfinite(y):
            raise ThrowingError(f"a throw's across offset must be finite (m), got {across!r}")
        h = self._features(landing)[0]
        corners = self._features(
            np.vstack([np.asarray(within, dtype=float).reshape(-1, 2), np.reshape(landing, (1, 2))])
        )
        P = self.P + np.diag(np.square(WALK_M))
        Ph = P @ h
        nu = float(y - h @ self.w)
        reach = float(np.max(np.abs(corners @ Ph)))  # the move at the worst corner is reach |nu| / s
        s = max(float(h @ Ph) + NOISE_M**2, reach * abs(nu) / STEP_BOUND_M)
        k = Ph / s
        self.w = self.w + k * nu
        self.P = P - np.outer(k, Ph)
        self.P = 0.5 * (self.P + self.P.T)
        self.updates += 1
        return float(reach * abs(nu) / s)

    def to_dict(self) -> dict[str, object]:
        return {
            "origin_xz_m": self.origin.tolist(),
            "spread_xz_m": self.spread.tolist(),
            "w_m": self.w.tolist(),
            "covariance_m2": self.P.tolist(),
            "updates": self.updates,
        }

    @classmethod
    def from_dict(cls, d: Mapping[str, Any]) -> LateralTerm:
        """The term `to_dict` wrote; LibraryFormatError for anything else."""
        try:
            return cls(d["origin_xz_m"], d["spread_xz_m"], d["w_m"], d["covariance_m2"], int(d["updates"]))
        except (KeyError, TypeError, ValueError, ThrowingError) as exc:
            raise LibraryFormatError(f"bad sideways term in the library: {exc}") from None
