"""The simulated operator: its throws land on their targets (noise-free), stay within the speed cap,
vary smoothly with the target, and unreachable targets are refused clearly."""

from __future__ import annotations

import numpy as np
import pytest

from wiithrow.throwing.errors import UnreachableTargetError
from wiithrow.throwing.forward import predict_landing
from wiithrow.throwing.operator import OperatorSettings, relative_speed, solve_throw
from wiithrow.throwing.representation import ThrowShape


def test_throws_land_on_their_targets_within_the_cap(pa10):
    shape = ThrowShape()
    for target in [(1.0, 0.0), (1.6, 0.0), (1.0, 0.4), (1.6, 0.4), (1.3, 0.2)]:
        p = solve_throw(pa10, target)
        land = predict_landing(pa10, shape, p, target[1])
        assert abs(land.xz[0] - target[0]) < 1e-6
        assert relative_speed(pa10, shape, p) <= 0.9 * 0.95 + 1e-9
        shape.check(pa10, p)
    # the far-high corner of the training area needs the most: about 84 % of the limits
    assert 0.8 < relative_speed(pa10, shape, solve_throw(pa10, (1.6, 0.4))) < 0.855


def test_parameters_vary_smoothly_with_the_target(pa10):
    """The operator's optimum is a smooth (C^2) function of the target: halving the step of a
    second difference divides it by ~4 (a kink would give ~2, a jump between optimum branches ~1)."""

    def theta(x, z):
        return solve_throw(pa10, (x, z)).vector

    for z in (0.0, 0.4):
        for x in (1.05, 1.3, 1.55):
            d2 = [np.linalg.norm(theta(x + h, z) - 2 * theta(x, z) + theta(x - h, z)) for h in (0.02, 0.01)]
            assert 3.5 < d2[0] / d2[1] < 4.5, (x, z, d2)
    # more distance needs more speed of every joint
    xs = np.linspace(1.0, 1.6, 7)
    speeds = np.array([theta(x, 0.2)[3:] for x in xs])
    assert np.all(np.diff(speeds, axis=0) > 0)


def test_unreachable_target_is_refused(pa10):
    with pytest.raises(UnreachableTargetError, match=r"\(2\.500, 0\.400\).*short"):
        solve_throw(pa10, (2.5, 0.4))
    with pytest.raises(UnreachableTargetError):
        solve_throw(pa10, (1.3, 0.2), settings=OperatorSettings(speed_cap=0.2))
