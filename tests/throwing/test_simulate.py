"""The stand-in execution: it executes only validated throws, lands where predicted without noise,
and its noise is seeded and of the stated size."""

from __future__ import annotations

import numpy as np
import pytest

from wiithrow.throwing.errors import ThrowingError
from wiithrow.throwing.limiting import plan_throw
from wiithrow.throwing.operator import solve_throw
from wiithrow.throwing.release import ExecutionNoise
from wiithrow.throwing.simulate import SimulatedExecution
from wiithrow.throwing.validator import require_valid


@pytest.fixture(scope="module")
def throw(pa10):
    p = solve_throw(pa10, (1.4, 0.3))
    return require_valid(plan_throw(pa10, p, 0.3, q1=-0.4, target=(1.4, 0.3)), pa10)


def test_noise_free_execution_lands_where_predicted(pa10, throw):
    ex = SimulatedExecution(pa10, np.random.default_rng(0), noise=ExecutionNoise.none(), measurement_sigma=0.0)
    out = ex.execute(throw)
    np.testing.assert_allclose(out.landing.link1, throw.predicted.link1, atol=1e-12)
    np.testing.assert_allclose(out.measured, throw.predicted.xz, atol=1e-12)
    assert out.error((1.4, 0.3)) < 1e-6


def test_measurement_noise_and_reproducibility(pa10, throw):
    ex = SimulatedExecution(pa10, np.random.default_rng(1), noise=ExecutionNoise.none(), measurement_sigma=0.002)
    M = np.array([ex.execute(throw).measured for _ in range(1000)]) - throw.predicted.xz
    assert np.all(np.abs(M.std(axis=0) - 0.002) < 0.0002)
    a = SimulatedExecution(pa10, np.random.default_rng(5)).execute(throw)
    b = SimulatedExecution(pa10, np.random.default_rng(5)).execute(throw)
    np.testing.assert_array_equal(a.measured, b.measured)


def test_execution_noise_moves_the_landing_by_millimetres(pa10, throw):
    ex = SimulatedExecution(pa10, np.random.default_rng(2), measurement_sigma=0.0)
    err = np.array([ex.execute(throw).error((1.4, 0.3)) for _ in range(300)])
    print(f"\nexecution noise only, (1.4, 0.3) m: rms landing error {1e3 * np.sqrt(np.mean(err**2)):.1f} mm")
    assert 0.0002 < np.sqrt(np.mean(err**2)) < 0.005


def test_only_validated_throws_are_executed(pa10, throw):
    ex = SimulatedExecution(pa10, np.random.default_rng(0))
    with pytest.raises(ThrowingError, match="ValidatedThrow"):
        ex.execute(throw.plan)
    with pytest.raises(ThrowingError, match="Generator"):
        SimulatedExecution(pa10, 0)
    # as execute_and_measure: plan, validate, execute
    m = ex(throw.params, (1.4, 0.3))
    assert np.linalg.norm(m - np.array([1.4, 0.3])) < 0.02
