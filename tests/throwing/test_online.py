"""The library that keeps learning (`throwing.online`): before any join it is the training fit,
online updates equal a solve from scratch on the same throws, the size bound and the supersession
retire what they say, the trained area grows with a landing beyond it, and the state survives
its file."""

from __future__ import annotations

import numpy as np
import pytest

from wiithrow.throwing.errors import ThrowingError
from wiithrow.throwing.forward import predict_landing
from wiithrow.throwing.generalize import Generalizer
from wiithrow.throwing.library import ThrowLibrary, TrainedThrow
from wiithrow.throwing.online import OnlineLibrary, batch_fit
from wiithrow.throwing.simulate import simulated_library


@pytest.fixture(scope="module")
def library(pa10) -> ThrowLibrary:
    return simulated_library(pa10, seed=0)


def _throw(online: OnlineLibrary, landing, rng: np.random.Generator, shift=(0.0, 0.0)) -> TrainedThrow:
    """A throw the regression gives for `landing`, labelled `shift` (m) away, with 2 mm of noise."""
    landing = np.asarray(landing, float)
    measured = landing + np.asarray(shift) + rng.normal(0.0, 0.002, 2)
    return TrainedThrow(landing, online.predict(landing), measured)


def _grid(library: ThrowLibrary) -> np.ndarray:
    L = library.landings
    X, Z = np.meshgrid(np.linspace(L[:, 0].min(), L[:, 0].max(), 7), np.linspace(L[:, 1].min(), L[:, 1].max(), 5))
    return np.column_stack([X.ravel(), Z.ravel()])


def test_before_any_join_it_is_the_training_fit(library):
    online = OnlineLibrary.start(library)
    grid = _grid(library)
    expected = Generalizer(library).gp.predict(grid)
    assert np.max(np.abs(online.predict_vector(grid) - expected)) < 1e-9
    assert len(online) == len(library) and online.area.bounds == Generalizer(library).area.bounds


def test_online_updates_equal_a_solve_from_scratch(library):
    """40 joins (with supersessions and a bound of 50 throws: both retire) against the same
    regression solved from nothing on the throws kept, with their join numbers."""
    rng = np.random.default_rng(4)
    online = OnlineLibrary.start(library, max_size=50)
    for _ in range(40):
        online.add(_throw(online, rng.uniform((1.0, 0.0), (1.6, 0.4)), rng, (0.01, 0.0)), time="t", source="test")
    assert sum(len(u.retired) for u in online.history) > 0
    kept = online.library
    batch = batch_fit(kept, Generalizer(library).gp, online.joined, drift_throws=online.drift_throws)
    grid = _grid(library)
    a, b = online.predict_vector(grid), batch.predict_vector(grid)
    scale = np.abs(b).max(axis=0)
    assert np.max(np.abs(a - b) / scale) < 1e-8


def test_the_size_bound_retires_the_oldest(library):
    rng = np.random.default_rng(5)
    online = OnlineLibrary.start(library, max_size=30, supersede_m=0.0)
    oldest = []
    for k in range(12):
        update = online.add(_throw(online, rng.uniform((1.0, 0.0), (1.6, 0.4)), rng), time=f"t{k}", source="test")
        oldest += [why for _, why in update.retired]
        assert len(online) <= 30
    assert len(online) == 30
    assert len(oldest) == 25 + 12 - 30 and all("oldest" in why for why in oldest)
    # the trained throws went first (join number 0), the 12 new ones all stay
    assert sorted(online.joined.tolist()) == [0] * 18 + list(range(1, 13))


def test_a_throw_supersedes_older_ones_in_its_neighbourhood(library):
    online = OnlineLibrary.start(library, supersede_m=0.03)
    landing = library.landings[7]
    rng = np.random.default_rng(6)
    update = online.add(_throw(online, landing + (0.01, 0.0), rng), time="t", source="test")
    near = np.hypot(*(library.landings - update.throw.landing).T) <= 0.03
    assert len(update.retired) == int(near.sum()) >= 1
    assert all(why.startswith("superseded") for _, why in update.retired)
    assert len(online) == len(library) - int(near.sum()) + 1


def test_the_trained_area_grows_to_a_landing_beyond_it(library):
    online = OnlineLibrary.start(library)
    (_, x1), _ = online.area.bounds
    beyond = np.array([x1 + 0.05, 0.2])
    assert online.area.distance_outside(beyond) > 0.04
    online.add(_throw(online, beyond, np.random.default_rng(7)), time="t", source="test")
    assert online.area.distance_outside(beyond) < 0.005  # the measured landing, 2 mm noise, is a corner now
    assert online.area.bounds[0][1] > x1 + 0.04


def test_a_drift_is_followed(library, pa10):
    """A drifted world: every throw lands 2 cm further than the planner's model flies it (noise-free,
    with drag) plus 1 mm of label noise. After 10 measured throws at other targets the regression's
    throws land within a few mm of the probes again, without retraining."""
    rng = np.random.default_rng(8)
    online = OnlineLibrary.start(library)
    shift = np.array([0.02, 0.0])

    def landed(params, height: float) -> np.ndarray:
        return predict_landing(pa10, library.shape, params, height, 0.0, library.ball).xz + shift

    probes = rng.uniform((1.1, 0.05), (1.5, 0.35), (12, 2))

    def median_error() -> float:
        return float(np.median([np.hypot(*(landed(online.predict(p), p[1]) - p)) for p in probes]))

    before = median_error()
    for target in rng.uniform((1.05, 0.02), (1.55, 0.38), (10, 2)):
        params = online.predict(target)
        online.add(
            TrainedThrow(target, params, landed(params, target[1]) + rng.normal(0.0, 0.001, 2)), time="t", source="test"
        )
    after = median_error()
    print(f"\ndrift of 20 mm: median error {1e3 * before:.1f} mm before, {1e3 * after:.1f} mm after 10 throws")
    assert before > 0.015 and after < 0.006, (before, after)


def test_the_state_and_history_survive_the_library(library):
    rng = np.random.default_rng(9)
    online = OnlineLibrary.start(library)
    for k in range(5):
        online.add(_throw(online, rng.uniform((1.0, 0.0), (1.6, 0.4)), rng), time=f"t{k}", source="test")
    saved = ThrowLibrary.from_dict(online.library.to_dict())
    again = OnlineLibrary.start(saved)
    grid = _grid(library)
    assert np.max(np.abs(again.predict_vector(grid) - online.predict_vector(grid))) < 1e-9
    assert [u.time for u in again.history] == [f"t{k}" for k in range(5)]
    assert again.joined.tolist() == online.joined.tolist()


def test_a_bad_throw_changes_nothing(library, pa10):
    online = OnlineLibrary.start(library)
    with pytest.raises(ThrowingError, match="TrainedThrow"):
        online.add((1.3, 0.2), time="t", source="test")  # type: ignore[arg-type]
    other = simulated_library(pa10, seed=1, targets=[[1.2, 0.1], [1.3, 0.2], [1.4, 0.1], [1.3, 0.0]])
    assert len(online) == len(library) and not online.history
    assert other.shape == library.shape  # the same shape: the join is accepted, and counted
    online.add(other.throws[0], time="t", source="test")
    assert len(online.history) == 1
