"""Generalization: GP regression over the library reproduces the trained throws, the
leave-one-out landing error is a few mm, and targets outside the trained area are refused."""

from __future__ import annotations

import numpy as np
import pytest

from wiithrow.throwing.errors import OutsideTrainedAreaError, ThrowingError
from wiithrow.throwing.forward import predict_landing
from wiithrow.throwing.generalize import Generalizer, TrainedArea, leave_one_out_error
from wiithrow.throwing.release import ExecutionNoise
from wiithrow.throwing.simulate import simulated_library


@pytest.fixture(scope="module")
def library(pa10):
    return simulated_library(pa10, seed=0)  # noise: jitter 2 ms, tracking 1 mrad, measurement 2 mm


def test_leave_one_out_error_is_a_few_mm(pa10, library):
    loo = leave_one_out_error(library, pa10)
    print(f"\n{loo}")  # measured (seed 0): mean 3.2 mm, median 2.3 mm, rms 4.7 mm, max 17.9 mm
    assert loo.errors.shape == (25,)
    assert loo.median < 0.005 and loo.mean < 0.006 and loo.max < 0.025


def test_leave_one_out_error_without_noise_is_the_regression_error(pa10):
    clean = simulated_library(pa10, seed=0, noise=ExecutionNoise.none(), measurement_sigma=0.0)
    loo = leave_one_out_error(clean, pa10)
    print(f"\nnoise-free {loo}")  # measured: mean 0.9 mm, median 0.6 mm, max 2.8 mm
    assert loo.mean < 0.002 and loo.max < 0.005


def test_prediction_inside_the_area_lands_on_the_target(pa10, library):
    """Noise-free landing of the regressed throw vs the target, on a grid inside the area."""
    gen = Generalizer(library)
    errs = []
    for x in np.linspace(1.05, 1.55, 6):
        for z in np.linspace(0.05, 0.35, 4):
            land = predict_landing(pa10, library.shape, gen.params_for((x, z)), z)
            errs.append(abs(land.xz[0] - x))
    assert np.median(errs) < 0.005 and np.max(errs) < 0.012


def test_targets_outside_the_trained_area_are_refused(library):
    gen = Generalizer(library)
    pattern = r"0\.2\d\d m outside the trained area .*convex hull of the 25"
    with pytest.raises(OutsideTrainedAreaError, match=pattern) as e:
        gen.params_for((1.85, 0.2))
    assert e.value.distance == pytest.approx(1.85 - gen.area.bounds[0][1], abs=0.02)
    assert e.value.target == (1.85, 0.2)
    # a stated margin lets a near target through, not a far one
    x_edge = gen.area.bounds[0][1]
    gen.params_for((x_edge + 0.02, 0.2), margin=0.05)
    with pytest.raises(OutsideTrainedAreaError, match="margin of 0.050 m"):
        gen.params_for((x_edge + 0.1, 0.2), margin=0.05)
    with pytest.raises(ThrowingError, match="margin"):
        gen.params_for((1.3, 0.2), margin=-1.0)


def test_trained_area_distance_is_euclidean():
    area = TrainedArea([[0, 0], [1, 0], [1, 1], [0, 1], [0.5, 0.5]])
    assert area.distance_outside((0.5, 0.5)) == 0.0
    assert area.distance_outside((1.0, 0.5)) == 0.0
    assert area.distance_outside((1.3, 0.5)) == pytest.approx(0.3)
    assert area.distance_outside((1.3, 1.4)) == pytest.approx(0.5)
    assert area.contains((1.05, 0.5), margin=0.1) and not area.contains((1.05, 0.5))
    assert area.bounds == ((0.0, 1.0), (0.0, 1.0))
    with pytest.raises(ThrowingError, match="collinear"):
        TrainedArea([[0, 0], [1, 1], [2, 2]])
