"""A small Gaussian process regressor: ARD squared-exponential kernel + noise, linear mean,
hyperparameters by maximum marginal likelihood (scipy.optimize, analytic gradient).

Model, per output dimension (outputs are independent GPs; inputs x in R^d are standardized first):

    y(x) = b0 + b^T x + f(x) + eps,    f ~ GP(0, k),    eps ~ N(0, sn^2)
    k(x, x') = sf^2 exp(-1/2 sum_i (x_i - x'_i)^2 / l_i^2)                    (ARD RBF)

The linear mean (b0, b) is fitted by least squares; its residuals r, divided by their standard
deviation, are the GP's targets. Hyperparameters h = (log l_1..l_d, log sf, log sn) minimise the
negative log marginal likelihood

    NLL(h) = 1/2 r^T K^-1 r + sum log diag(L) + n/2 log(2 pi),   K = k(X, X) + sn^2 I = L L^T
    dNLL/dh_k = -1/2 tr((alpha alpha^T - K^-1) dK/dh_k),   alpha = K^-1 r

with dK/dlog l_i = K_f * (x_i - x'_i)^2 / l_i^2, dK/dlog sf = 2 K_f, dK/dlog sn = 2 sn^2 I, by
SLSQP (bounded; lighter per iteration than scipy's L-BFGS-B here) from a few fixed starting points
(deterministic) inside bounds that keep it well posed.
The prediction at x* is  b0 + b^T x* + std(r) k(x*, X) alpha  (and a variance if asked).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Literal, overload

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.linalg import cho_factor, cho_solve
from scipy.optimize import minimize

from wiithrow.throwing.errors import ThrowingError

#: Bounds of the hyperparameters (standardized inputs and outputs).
LENGTH_BOUNDS = (0.25, 20.0)  # standardized inputs: below ~ the spacing of 25 samples, a length is noise-fitting
SIGNAL_BOUNDS = (1e-3, 100.0)
NOISE_BOUNDS = (1e-5, 1.0)


@dataclass(frozen=True)
class GPHyperparameters:
    """Fitted hyperparameters of one output (standardized units): `lengths` (d,), `signal`, `noise`,
    and the negative log marginal likelihood `nll` at them."""

    lengths: NDArray[np.float64]
    signal: float
    noise: float
    nll: float


def _nll_and_grad(
    h: NDArray[np.float64], X: NDArray[np.float64], y: NDArray[np.float64], D2: NDArray[np.float64]
) -> tuple[float, NDArray[np.float64]]:
    d = X.shape[1]
    ell = np.exp(h[:d])
    sf2 = math.exp(2 * h[d])
    sn2 = math.exp(2 * h[d + 1])
    n = y.size
    S = np.tensordot(D2, 1.0 / ell**2, axes=([2], [0]))  # sum_i (x_i - x'_i)^2 / l_i^2
    Kf = sf2 * np.exp(-0.5 * S)
    K = Kf + sn2 * np.eye(n)
    try:
        c, low = cho_factor(K, lower=True)
    except np.linalg.LinAlgError:
        return 1e25, np.zeros_like(h)
    alpha = cho_solve((c, low), y)
    nll = 0.5 * y @ alpha + np.sum(np.log(np.diag(c))) + 0.5 * n * math.log(2 * math.pi)
    W = np.outer(alpha, alpha) - cho_solve((c, low), np.eye(n))
    g = np.empty_like(h)
    for i in range(d):
        g[i] = -0.5 * np.sum(W * Kf * D2[:, :, i] / ell[i] ** 2)
    g[d] = -0.5 * np.sum(W * 2 * Kf)
    g[d + 1] = -0.5 * np.trace(W) * 2 * sn2
    return float(nll), g


class GaussianProcess:
    """Independent GPs for every output column (module docstring). `fit(X, Y)` then `predict(Xs)`."""

    def __init__(self) -> None:
        self.hyper: list[GPHyperparameters] = []
        self._fitted = False
        # set by `fit` (module docstring): input standardization, linear mean, GP weights
        self.x_mean: NDArray[np.float64] = np.zeros(0)
        self.x_std: NDArray[np.float64] = np.ones(0)
        self.beta: NDArray[np.float64] = np.zeros((0, 0))  # (d + 1, m)
        self.r_std: NDArray[np.float64] = np.ones(0)  # (m,)
        self.Xn: NDArray[np.float64] = np.zeros((0, 0))  # (N, d) standardized inputs
        self.alpha: NDArray[np.float64] = np.zeros((0, 0))  # (m, N)
        self.lengths: NDArray[np.float64] = np.zeros((0, 0))  # (m, d)
        self.signal2: NDArray[np.float64] = np.zeros(0)  # (m,)
        self._chol: list[tuple[NDArray[np.float64], bool]] = []  # Cholesky factors of K per output

    def fit(self, X: ArrayLike, Y: ArrayLike, initial: list[GPHyperparameters] | None = None) -> GaussianProcess:
        """Fit to inputs X (N, d) and outputs Y (N, m); N >= d + 2. `initial`: hyperparameters per
        output to start the likelihood maximisation from (e.g. a fit to more data), instead of the
        fixed starting points."""
        X = np.asarray(X, dtype=np.float64)
        Y = np.asarray(Y, dtype=np.float64)
        if X.ndim != 2 or Y.ndim != 2 or X.shape[0] != Y.shape[0]:
            raise ThrowingError(f"GP needs X (N, d) and Y (N, m), got {X.shape} and {Y.shape}")
        n, d = X.shape
        if n < d + 2:
            raise ThrowingError(f"GP needs at least {d + 2} samples, got {n}")
        if not (np.all(np.isfinite(X)) and np.all(np.isfinite(Y))):
            raise ThrowingError("GP training data must be finite")
        self.x_mean = X.mean(axis=0)
        self.x_std = X.std(axis=0)
        self.x_std[self.x_std == 0] = 1.0
        Xn = (X - self.x_mean) / self.x_std
        H = np.hstack([np.ones((n, 1)), Xn])
        self.beta, *_ = np.linalg.lstsq(H, Y, rcond=None)  # (d + 1, m)
        Rz = Y - H @ self.beta
        self.r_std = Rz.std(axis=0)
        self.r_std[self.r_std == 0] = 1.0
        Rn = Rz / self.r_std
        D2 = (Xn[:, None, :] - Xn[None, :, :]) ** 2
        bounds = [tuple(np.log(LENGTH_BOUNDS))] * d + [tuple(np.log(SIGNAL_BOUNDS)), tuple(np.log(NOISE_BOUNDS))]
        starts = [np.r_[np.full(d, math.log(ell)), 0.0, math.log(sn)] for ell in (0.5, 1.5) for sn in (0.01, 0.2)]
        alphas: list[NDArray[np.float64]] = []
        self.hyper, self._chol = [], []
        self.Xn = Xn
        for k in range(Y.shape[1]):
            y = Rn[:, k]
            if initial is not None:
                hp0 = initial[k]
                h_starts = [np.clip(np.log(np.r_[hp0.lengths, hp0.signal, hp0.noise]), *np.array(bounds).T)]
            else:
                h_starts = starts
            fits = [
                minimize(
                    _nll_and_grad,
                    h0,
                    args=(Xn, y, D2),
                    jac=True,
                    method="SLSQP",
                    bounds=bounds,
                    options={"maxiter": 200, "ftol": 1e-10},
                )
                for h0 in h_starts
            ]
            best = min(fits, key=lambda res: res.fun)  # the first of the lowest
            h = best.x
            hp = GPHyperparameters(np.exp(h[:d]), float(math.exp(h[d])), float(math.exp(h[d + 1])), float(best.fun))
            K = self._k(Xn, Xn, hp) + hp.noise**2 * np.eye(n)
            cf = cho_factor(K, lower=True)
            alphas.append(cho_solve(cf, y))
            self.hyper.append(hp)
            self._chol.append(cf)
        self.alpha = np.array(alphas)  # (m, N)
        self.lengths = np.array([hp.lengths for hp in self.hyper])  # (m, d)
        self.signal2 = np.array([hp.signal**2 for hp in self.hyper])  # (m,)
        self._fitted = True
        return self

    @staticmethod
    def _k(A: NDArray[np.float64], B: NDArray[np.float64], hp: GPHyperparameters) -> NDArray[np.float64]:
        S = (((A[:, None, :] - B[None, :, :]) / hp.lengths) ** 2).sum(axis=2)
        K: NDArray[np.float64] = hp.signal**2 * np.exp(-0.5 * S)
        return K

    @overload
    def predict(self, Xs: ArrayLike, return_std: Literal[False] = False) -> NDArray[np.float64]: ...
    @overload
    def predict(self, Xs: ArrayLike, return_std: Literal[True]) -> tuple[NDArray[np.float64], NDArray[np.float64]]: ...
    def predict(
        self, Xs: ArrayLike, return_std: bool = False
    ) -> NDArray[np.float64] | tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Mean (M, m) at inputs Xs (M, d); with return_std also the predictive std of f (M, m)."""
        if not self._fitted:
            raise ThrowingError("the GP is not fitted")
        Xs = np.atleast_2d(np.asarray(Xs, dtype=np.float64))
        Z = (Xs - self.x_mean) / self.x_std
        diff = Z[:, None, None, :] - self.Xn[None, None, :, :]  # (M, 1, N, d)
        S = ((diff / self.lengths[None, :, None, :]) ** 2).sum(axis=3)  # (M, m, N)
        Ks = self.signal2[None, :, None] * np.exp(-0.5 * S)
        f = np.einsum("kmn,mn->km", Ks, self.alpha)
        H = np.hstack([np.ones((Z.shape[0], 1)), Z])
        mean: NDArray[np.float64] = H @ self.beta + f * self.r_std
        if not return_std:
            return mean
        std = np.empty_like(mean)
        for m, cf in enumerate(self._chol):
            v = cho_solve(cf, Ks[:, m, :].T)  # (N, M)
            var = self.signal2[m] - np.sum(Ks[:, m, :].T * v, axis=0)
            std[:, m] = np.sqrt(np.maximum(var, 0.0)) * self.r_std[m]
        return mean, std
