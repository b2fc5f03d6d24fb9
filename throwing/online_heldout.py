"""The held-out error of a learning library, in closed form: what judges a learning update.

`heldout_errors(online, arm, near=..., count=...)` leaves each of the chosen throws out of the
regression in turn, with the hyperparameters, the linear mean and the drift process held fixed
(those of `online`: the training fit's, as `OnlineLibrary` keeps them), asks the regression for its
parameters at the throw's measured landing, and flies both those parameters and the throw's own by
the planner's model to the landing's height: the distance between the two landings is that
throw's held-out error (m), as `generalize.regression_leave_one_out_error` defines it for a
training.

With the hyperparameters fixed, leaving throw i out needs no refit (Rasmussen and Williams, eq.
5.12): per output m, with K_m the throws' covariance including the noise and r_m the standardised
residuals of the linear mean,

    alpha_m = K_m^-1 r_m,     mu_-i = r_i - alpha_i / [K_m^-1]_ii
    theta_-i[m] = Y[i, m] - r_std[m] alpha_m[i] / [K_m^-1]_ii

so every throw's held-out parameters cost one factorisation per output (six of at most 200 x 200:
a few ms) and two flights (0.05 ms each). The hyperparameters are not refitted without the throw,
so the figure is smaller than the refitted one of a training (`wiithrow train`'s): the shipped
25-throw library measures 1.4 mm mean here and 1.8 mm refitted, a 5-throw library 2.4 mm and
7.1 mm. It is used to compare a learning update with its parent, both measured the same way.

`near` and `count`: only the `count` throws whose landings lie nearest `near` are judged (an
update changes the regression around the throw that joined; a library of 200 throws would hide a
bad throw in its mean).

Pure: numpy and scipy, no app imports.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.linalg import cho_factor, cho_solve

from wiithrow.robot import ArmModel
from wiithrow.throwing.errors import ThrowingError
from wiithrow.throwing.forward import predict_landing
from wiithrow.throwing.library import TrainedThrow
from wiithrow.throwing.online import JITTER, OnlineLibrary, _one_blas_thread
from wiithrow.throwing.representation import ThrowParameters


class OwnLandings:
    """The model's landing of each throw's own parameters (link1 x, z), flown once per throw: a
    throw's own flight never changes while it is kept, and every update judges the throws around it
    again. Holds the throws it flew (so their ids stay theirs); `keep` forgets the others."""

    def __init__(self) -> None:
        self._flown: dict[int, tuple[TrainedThrow, NDArray[np.float64]]] = {}

    def get(self, online: OnlineLibrary, arm: ArmModel, throw: TrainedThrow) -> NDArray[np.float64]:
        known = self._flown.get(id(throw))
        if known is not None and known[0] is throw:
            return known[1]
        landing = predict_landing(arm, online.shape, throw.params, float(throw.landing[1]), 0.0, online.ball).link1
        self._flown[id(throw)] = (throw, landing)
        return landing

    def keep(self, throws: list[TrainedThrow]) -> None:
        alive = {id(t) for t in throws}
        self._flown = {k: v for k, v in self._flown.items() if k in alive}


def heldout_parameters(online: OnlineLibrary) -> NDArray[np.float64]:
    """(N, 2n): each throw's parameters predicted without it (module docstring), in the order of
    `online.throws`."""
    n = len(online.throws)
    H = np.hstack([np.ones((n, 1)), online.Xn])
    R = (online.Y - H @ online.beta) / online.r_std
    out = np.empty_like(online.Y)
    eye = np.eye(n)
    with _one_blas_thread():  # (as the library's own solve: two threads of a loaded host wait for each other)
        for m in range(online.Y.shape[1]):
            K = online.Kf[m] + eye * online.noise2[m]
            try:
                factor = cho_factor(K, lower=True, check_finite=False)
            except np.linalg.LinAlgError:  # two landings nearly alike: as the library's own solve does
                factor = cho_factor(K + eye * JITTER * online.signal2[m], lower=True, check_finite=False)
            inverse = cho_solve(factor, eye, check_finite=False)
            alpha = inverse @ R[:, m]
            out[:, m] = online.Y[:, m] - online.r_std[m] * alpha / np.diag(inverse)
    return out


def heldout_errors(
    online: OnlineLibrary,
    arm: ArmModel,
    *,
    near: ArrayLike | None = None,
    count: int | None = None,
    own: OwnLandings | None = None,
) -> NDArray[np.float64]:
    """Held-out landing errors (m) of the `count` throws nearest `near` ((x, z) in link1), or of
    every throw; infinite for a throw whose held-out parameters never reach its landing's height.
    `own`: the throws' own landings flown before (a learning library keeps one)."""
    own = own if own is not None else OwnLandings()
    landings = np.array([t.landing for t in online.throws])
    chosen = np.arange(len(online.throws))
    if near is not None and count is not None and count < len(chosen):
        distance = np.linalg.norm(landings - np.asarray(near, dtype=float), axis=1)
        chosen = np.argsort(distance, kind="stable")[:count]
    predicted = heldout_parameters(online)
    errors = np.empty(len(chosen))
    for k, i in enumerate(chosen):
        throw = online.throws[int(i)]
        height = float(throw.landing[1])
        try:
            held_out = ThrowParameters.from_vector(predicted[int(i)])
            a = predict_landing(arm, online.shape, held_out, height, 0.0, online.ball).link1
            b = own.get(online, arm, throw)
            errors[k] = float(np.hypot(a[0] - b[0], a[1] - b[1]))
        except ThrowingError:  # no landing at that height (or parameters no throw has): held out, it fails
            errors[k] = np.inf
    return errors
