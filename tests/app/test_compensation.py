"""The paper's claim: with labels and targets measured through the same wrong calibration, the
learned throws stay accurate; the same wrong calibration without retraining does not."""

import numpy as np
import pytest

from wiithrow.app.studies.compensation import distorted_calibration, distortion, run_compensation


def test_distorted_calibration_reports_the_distorted_point(sim_world):
    world = sim_world
    good = world.true_calibration()
    T = distortion(np.array([0.1, 0.0, 0.35]), 1.03, np.radians(1.0))
    wrong = distorted_calibration(good, T)
    X = np.array([[1.2, 0.05, 0.1]])
    pixels = np.stack([c.project(X) for c in world.cameras])
    measured = wrong.triangulate(pixels).points[0]
    assert np.allclose(measured, (T @ np.r_[X[0], 1.0])[:3], atol=1e-9)
    assert np.linalg.norm(measured - X[0]) > 0.03


@pytest.mark.slow
def test_learning_compensates_a_3_percent_1_degree_calibration_error():
    result = run_compensation(targets=8, seed=2)
    median = {case: float(np.nanmedian(e)) for case, e in result.errors.items()}
    assert all(np.isnan(e).sum() <= 1 for e in result.errors.values())
    assert median["compensated"] < 1.5 * median["true"] + 0.002, median
    assert median["uncompensated"] > 3 * median["compensated"], median
