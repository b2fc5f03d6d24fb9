"""The trained library: simulated training labels each throw with its measured landing, the files
round-trip with kind/schema checks, and broken files give clear errors."""

from __future__ import annotations

import json

import numpy as np
import pytest

from wiithrow.throwing.ballistics import Ball
from wiithrow.throwing.errors import LibraryFormatError, ThrowingError
from wiithrow.throwing.forward import predict_landing
from wiithrow.throwing.library import (
    KIND,
    SCHEMA,
    TRAINING_AREA,
    ThrowLibrary,
    TrainedThrow,
    simulate_training,
    training_targets,
)
from wiithrow.throwing.representation import ThrowParameters, ThrowShape
from wiithrow.throwing.simulate import SimulatedExecution


@pytest.fixture(scope="module")
def trained(pa10):
    """Training with a recording stand-in: what execute_and_measure was asked and what it answered."""
    execute = SimulatedExecution(pa10, np.random.default_rng(11))
    calls = []

    def execute_and_measure(params, target):
        measured = execute(params, target)
        calls.append((params, np.array(target), measured, execute.last))
        return measured

    lib = simulate_training(pa10, None, execute_and_measure, np.random.default_rng(10))
    return lib, calls


def test_training_grid_covers_the_area():
    T = training_targets()
    assert T.shape == (25, 2)
    assert T[:, 0].min() == TRAINING_AREA.x[0] and T[:, 0].max() == TRAINING_AREA.x[1]
    assert T[:, 1].min() == TRAINING_AREA.z[0] and T[:, 1].max() == TRAINING_AREA.z[1]
    assert str(TRAINING_AREA) == "x 1.00-1.60 m, z 0.00-0.40 m (link1)"


def test_labels_are_the_measured_landings(pa10, trained):
    lib, calls = trained
    assert len(lib) == 25 == len(calls)
    grid = training_targets()
    for k, (thr, (params, target, measured, outcome)) in enumerate(zip(lib.throws, calls)):
        # the operator aimed at a hand-placed marker near the grid point (x jitter 1 cm)
        assert abs(thr.target[0] - grid[k, 0]) < 0.05 and thr.target[1] == grid[k, 1]
        np.testing.assert_array_equal(thr.target, target)
        assert thr.params == params
        # noise-free, the operator's throw lands on the target
        assert abs(predict_landing(pa10, lib.shape, params, target[1]).xz[0] - target[0]) < 1e-6
        # the label is what was measured, not the target
        np.testing.assert_array_equal(thr.landing, measured)
        np.testing.assert_allclose(thr.landing, outcome.measured)
        assert not np.array_equal(thr.landing, thr.target)
    miss = np.linalg.norm(lib.landings - lib.targets, axis=1)
    assert 0.0005 < np.median(miss) < 0.01  # execution + measurement noise: a few mm
    assert lib.meta["targets"] == 25


def test_round_trip_through_json(trained):
    lib, _ = trained
    d = json.loads(json.dumps(lib.to_dict()))
    assert d["kind"] == KIND and d["schema"] == SCHEMA
    back = ThrowLibrary.from_dict(d)
    np.testing.assert_array_equal(back.parameters, lib.parameters)
    np.testing.assert_array_equal(back.landings, lib.landings)
    np.testing.assert_array_equal(back.targets, lib.targets)
    assert back.shape == lib.shape and back.ball == lib.ball and back.arm == "pa10"
    assert len(lib.without(3)) == 24


def test_wrong_files_are_refused_clearly(trained):
    lib, _ = trained
    d = lib.to_dict()
    with pytest.raises(LibraryFormatError, match="kind"):
        ThrowLibrary.from_dict({**d, "kind": "wiithrow.calibration"})
    with pytest.raises(LibraryFormatError, match="schema 2 is not supported"):
        ThrowLibrary.from_dict({**d, "schema": 2})
    with pytest.raises(LibraryFormatError, match="broken|bad"):
        ThrowLibrary.from_dict({**d, "throws": [{"target": [1, 0]}]})
    with pytest.raises(LibraryFormatError):
        ThrowLibrary.from_dict({k: v for k, v in d.items() if k != "ball"})
    with pytest.raises(LibraryFormatError):
        ThrowLibrary.from_dict([1, 2])
    with pytest.raises(ThrowingError, match="at least one"):
        ThrowLibrary("pa10", ThrowShape(), Ball(), ())
    with pytest.raises(ThrowingError):
        TrainedThrow(np.array([1.0, 0.0]), ThrowParameters([0.1], [0.2]), np.array([1.0]))


def test_training_needs_a_generator_and_reachable_targets(pa10):
    with pytest.raises(ThrowingError, match="Generator"):
        simulate_training(pa10, None, lambda p, t: t, None)
    with pytest.raises(ThrowingError, match="shape"):
        simulate_training(pa10, [1.0, 0.2], lambda p, t: t, np.random.default_rng(0))
