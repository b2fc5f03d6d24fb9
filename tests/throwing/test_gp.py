"""The small Gaussian process: analytic likelihood gradient, fit quality, noise estimate,
predictive uncertainty, determinism and input checks."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.optimize import approx_fprime

from wiithrow.throwing.errors import ThrowingError
from wiithrow.throwing.gp import GaussianProcess, _nll_and_grad


def data(rng, n=25, noise=0.01):
    X = rng.uniform([1.0, 0.0], [1.6, 0.4], (n, 2))
    f = lambda X: np.column_stack([np.sin(4 * X[:, 0]) + X[:, 1] ** 2, 3 * X[:, 0] - X[:, 1]])  # noqa: E731
    return X, f(X) + noise * rng.normal(size=(n, 2)), f


def test_likelihood_gradient_is_exact():
    rng = np.random.default_rng(0)
    X = rng.normal(size=(20, 2))
    y = rng.normal(size=20)
    D2 = (X[:, None] - X[None]) ** 2
    for h in (np.array([0.1, -0.3, 0.2, -2.0]), np.array([1.0, 0.5, -0.5, -4.0])):
        g = _nll_and_grad(h, X, y, D2)[1]
        fd = approx_fprime(h, lambda h: _nll_and_grad(h, X, y, D2)[0], 1e-7)
        np.testing.assert_allclose(g, fd, rtol=1e-4, atol=1e-5)


def test_fit_predicts_a_smooth_function_and_estimates_the_noise():
    rng = np.random.default_rng(1)
    X, Y, f = data(rng, noise=0.01)
    gp = GaussianProcess().fit(X, Y)
    Xt = rng.uniform([1.05, 0.02], [1.55, 0.38], (200, 2))
    err = np.abs(gp.predict(Xt) - f(Xt))
    assert err[:, 0].max() < 0.02  # a curved function from 25 noisy samples
    assert err[:, 1].max() < 0.01  # a linear one: the linear mean takes it
    # the fitted noise (standardized units times the residual std) is near the true 0.01
    est = gp.hyper[0].noise * gp.r_std[0]
    assert 0.004 < est < 0.02, est


def test_predictive_std_grows_away_from_the_data():
    rng = np.random.default_rng(2)
    X, Y, _ = data(rng)
    gp = GaussianProcess().fit(X, Y)
    _, s_in = gp.predict([[1.3, 0.2]], return_std=True)
    _, s_out = gp.predict([[2.5, 1.0]], return_std=True)
    assert s_out[0, 0] > 5 * s_in[0, 0]  # (the linear output has no GP signal: only its mean extrapolates)


def test_fit_is_deterministic_and_checks_its_input():
    rng = np.random.default_rng(3)
    X, Y, _ = data(rng)
    a = GaussianProcess().fit(X, Y).predict([[1.2, 0.1]])
    b = GaussianProcess().fit(X, Y).predict([[1.2, 0.1]])
    np.testing.assert_array_equal(a, b)
    with pytest.raises(ThrowingError, match="shape|X"):
        GaussianProcess().fit(X, Y[:-1])
    with pytest.raises(ThrowingError, match="at least"):
        GaussianProcess().fit(X[:3], Y[:3])
    with pytest.raises(ThrowingError, match="finite"):
        GaussianProcess().fit(np.vstack([X[:-1], [np.nan, 0]]), Y)
    with pytest.raises(ThrowingError, match="not fitted"):
        GaussianProcess().predict([[1, 2]])
