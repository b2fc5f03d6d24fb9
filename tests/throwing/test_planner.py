"""The whole throwing pipeline, measured: target -> generalized parameters -> Ruckig -> validator.

Every plan for 200 seeded random targets in the trained area passes the validator; with the
stand-in execution noise (release jitter 2 ms, tracking 1 mrad, measurement 2 mm in the training
labels) the landing error and the repeatability meet the project's goals; planning is fast."""

from __future__ import annotations

import numpy as np
import pytest

from wiithrow.robot import check_trajectory
from wiithrow.throwing.errors import OutsideTrainedAreaError
from wiithrow.throwing.planner import ThrowPlanner
from wiithrow.throwing.simulate import SimulatedExecution, simulated_library
from wiithrow.throwing.validator import ValidatedThrow


@pytest.fixture(scope="module")
def planner(pa10):
    return ThrowPlanner(pa10, simulated_library(pa10, seed=0))


def targets_in_area(planner, n, seed):
    rng = np.random.default_rng(seed)
    (x0, x1), (z0, z1) = planner.area.bounds
    out = []
    while len(out) < n:
        p = rng.uniform([x0, z0], [x1, z1])
        if planner.area.contains(p):
            out.append(p)
    return np.array(out)


def test_every_plan_for_200_targets_passes_the_validator(pa10, planner):
    rng = np.random.default_rng(100)
    for target in targets_in_area(planner, 200, seed=101):
        q1 = rng.uniform(-1.5, 1.5)
        throw = planner.plan(target, q1)
        assert isinstance(throw, ValidatedThrow) and throw.report.ok
        check_trajectory(throw.trajectory, pa10, tol=1e-9, check_jerk=True)  # a second, independent opinion
        k = throw.plan.release_index
        assert np.max(np.abs(throw.trajectory.positions[k] - throw.release.q)) < 1e-9
        assert np.max(np.abs(throw.trajectory.velocities[k] - throw.release.dq)) < 1e-9
        assert throw.report.min_clearance > 0.05


def test_landing_error_with_execution_noise(pa10, planner):
    execute = SimulatedExecution(pa10, np.random.default_rng(200))
    errors = []
    rng = np.random.default_rng(201)
    for target in targets_in_area(planner, 200, seed=202):
        throw = planner.plan(target, rng.uniform(-1.5, 1.5))
        errors.append(execute.execute(throw).error(target))
    errors = np.array(errors)
    med, p95 = np.median(errors), np.percentile(errors, 95)
    print(
        f"\nlanding error over 200 targets: median {1e3 * med:.1f} mm, p95 {1e3 * p95:.1f} mm, "
        f"max {1e3 * errors.max():.1f} mm"
    )  # measured: median 1.6 mm, p95 4.7 mm
    assert med <= 0.02 and p95 <= 0.05  # the project's goals
    assert med <= 0.005 and p95 <= 0.012  # what this implementation achieves, with margin


def test_repeatability_at_one_target(pa10, planner):
    execute = SimulatedExecution(pa10, np.random.default_rng(300))
    throw = planner.plan((1.3, 0.2), 0.4)
    landings = np.array([execute.execute(throw).landing.link1[:2] for _ in range(20)])  # (x, y) in link1
    spread = np.linalg.norm(landings - landings.mean(axis=0), axis=1).max()
    print(
        f"\nrepeatability, 20 throws at (1.3, 0.2) m: largest distance from the mean landing "
        f"{1e3 * spread:.1f} mm, std x {1e3 * landings[:, 0].std():.1f} mm, y {1e3 * landings[:, 1].std():.1f} mm"
    )
    assert spread <= 0.02  # the project's goal
    assert spread <= 0.008  # measured: about 3-4 mm


def test_targets_outside_the_area_and_the_margin(pa10, planner):
    with pytest.raises(OutsideTrainedAreaError, match="outside the trained area"):
        planner.plan((2.0, 0.2))
    x_edge = planner.area.bounds[0][1]
    throw = planner.plan((x_edge + 0.02, 0.2), margin=0.03)
    assert abs(throw.predicted.xz[0] - (x_edge + 0.02)) < 0.02
    wide = ThrowPlanner(pa10, planner.library, margin=0.03)
    wide.plan((x_edge + 0.02, 0.2))


def test_plan_with_a_prelude_from_home(pa10, planner):
    throw = planner.plan((1.2, 0.1), 0.6, q_start=pa10.home)
    np.testing.assert_allclose(throw.trajectory.positions[0], pa10.home)
    assert throw.trajectory.positions[-1][0] == pytest.approx(0.6)
    assert throw.report.ok
