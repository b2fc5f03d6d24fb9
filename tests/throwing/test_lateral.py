"""The learned sideways term (`throwing.lateral`) and how the library keeps it: fitted from the
throws' across labels (none: no correction), a steady miss learned within a few joins and an
angle too, no update moving it by more than its bound (a landing a metre to the side included),
the aim that turns joint 1 so that the offset lands on the target, and library files with and
without the labels and the learned state."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from wiithrow.throwing.errors import LibraryFormatError, ThrowingError
from wiithrow.throwing.lateral import STEP_BOUND_M, LateralTerm, aim_at
from wiithrow.throwing.library import ThrowLibrary, TrainedThrow
from wiithrow.throwing.online import META_KEY, OnlineLibrary
from wiithrow.throwing.planner import AnalyticPlanner, ThrowPlanner
from wiithrow.throwing.simulate import simulated_library

CORNERS = np.array([[1.0, 0.0], [1.6, 0.0], [1.6, 0.4], [1.0, 0.4]])


@pytest.fixture(scope="module")
def library(pa10) -> ThrowLibrary:
    return simulated_library(pa10, seed=0)


def _labelled(library: ThrowLibrary, across) -> ThrowLibrary:
    throws = tuple(dataclasses.replace(t, across=float(a)) for t, a in zip(library.throws, across))
    return dataclasses.replace(library, throws=throws)


def test_a_library_without_labels_has_no_correction_and_its_labels_fit_one(library):
    assert np.isnan(library.across).all()
    assert LateralTerm.fit(library.landings, library.across).across((1.3, 0.2)) == 0.0
    rng = np.random.default_rng(0)
    offset = 0.015 + rng.normal(0, 0.002, len(library))  # a steady 15 mm miss, 2 mm of noise
    term = LateralTerm.fit(library.landings, offset)
    assert all(abs(term.across(p) - 0.015) < 0.002 for p in CORNERS)
    # an angle: the miss grows with the distance (10 mrad)
    angle = LateralTerm.fit(library.landings, 0.010 * library.landings[:, 0])
    assert all(abs(angle.across(p) - 0.010 * p[0]) < 0.001 for p in CORNERS)


def test_a_steady_miss_is_learned_in_a_few_joins_and_no_join_moves_it_beyond_the_bound():
    rng = np.random.default_rng(1)
    term = LateralTerm.fit(CORNERS, np.full(4, np.nan))
    before = [term.across(p) for p in CORNERS]
    for k in range(10):
        landing = rng.uniform((1.0, 0.0), (1.6, 0.4))
        move = term.update(landing, 0.015 + rng.normal(0, 0.002), CORNERS)
        after = [term.across(p) for p in CORNERS]
        assert move <= STEP_BOUND_M + 1e-12 and max(abs(a - b) for a, b in zip(after, before)) <= STEP_BOUND_M + 1e-12
        before = after
        if k == 2:
            assert all(abs(a - 0.015) < 0.004 for a in after), after  # three throws take most of it
    assert all(abs(a - 0.015) < 0.002 for a in before) and term.updates == 10
    # a landing a metre to the side (a marker put in the wrong place) moves it by the bound at most
    wild = term.update((1.3, 0.2), 1.0, CORNERS)
    moved = [abs(term.across(p) - b) for p, b in zip(CORNERS, before)]
    assert wild == pytest.approx(STEP_BOUND_M) and max(moved) == pytest.approx(STEP_BOUND_M)
    with pytest.raises(ThrowingError, match="finite"):
        term.update((1.3, 0.2), math.nan, CORNERS)


def test_a_new_miss_after_training_is_followed(library):
    """A library whose labels said "no sideways miss" (25 labels of 0 +- 2 mm) follows a 15 mm miss
    that appears afterwards: the random walk lets the new labels in."""
    rng = np.random.default_rng(2)
    term = LateralTerm.fit(library.landings, rng.normal(0, 0.002, len(library)))
    for _ in range(15):
        term.update(rng.uniform((1.0, 0.0), (1.6, 0.4)), 0.015 + rng.normal(0, 0.002), CORNERS)
    assert abs(term.across((1.3, 0.2)) - 0.015) < 0.004


def test_the_aim_turns_joint_1_so_that_the_offset_lands_on_the_target():
    aim = aim_at(0.015, 1.3, 0.2, 0.5)
    # the throw lands (x, 0.015) in its plane, its plane turned to aim.q1: the landing in base
    landing = np.array(
        [
            aim.xz[0] * math.cos(aim.q1) - 0.015 * math.sin(aim.q1),
            aim.xz[0] * math.sin(aim.q1) + 0.015 * math.cos(aim.q1),
        ]
    )
    np.testing.assert_allclose(landing, [1.3 * math.cos(0.5), 1.3 * math.sin(0.5)], atol=1e-12)
    assert aim.q1 < 0.5 and aim.across_m == 0.015 and aim.xz[1] == 0.2
    with pytest.raises(ThrowingError, match="within the sideways offset"):
        aim_at(0.5, 0.3, 0.0, 0.0)


def test_the_planner_aims_with_the_learned_term_and_the_analytic_planner_does_not(library, pa10):
    labelled = _labelled(library, np.full(len(library), 0.015))
    planner = ThrowPlanner(pa10, labelled)
    aim = planner.aim(1.3, 0.2, 0.1)
    assert aim.across_m == pytest.approx(0.015, abs=0.001) and aim.q1 == pytest.approx(0.1 - 0.015 / 1.3, abs=1e-3)
    throw = planner.plan(aim.xz, q1=aim.q1)
    assert throw.q1 == aim.q1
    assert AnalyticPlanner(pa10, labelled).aim(1.3, 0.2, 0.1).q1 == 0.1


def test_labels_and_the_learned_state_survive_the_file_and_old_files_load_with_no_term(library):
    old = library.to_dict()
    assert all("across" not in t for t in old["throws"])  # a file from before the labels were kept
    assert OnlineLibrary.start(ThrowLibrary.from_dict(old)).across((1.3, 0.2)) == 0.0
    labelled = _labelled(library, np.full(len(library), 0.01))
    back = ThrowLibrary.from_dict(labelled.to_dict())
    np.testing.assert_allclose(back.across, 0.01)
    online = OnlineLibrary.start(back)
    throw = library.throws[3]
    online.add(TrainedThrow(throw.target, throw.params, throw.landing, 0.02), time="t", source="test")
    learned = online.across((1.3, 0.2))
    saved = online.library.to_dict()
    assert saved["meta"][META_KEY]["lateral"]["updates"] == 1
    resumed = OnlineLibrary.start(ThrowLibrary.from_dict(saved))
    assert resumed.across((1.3, 0.2)) == pytest.approx(learned, abs=1e-15)
    # a library that learnt before the term was kept starts from its labels
    del saved["meta"][META_KEY]["lateral"]
    assert OnlineLibrary.start(ThrowLibrary.from_dict(saved)).across((1.3, 0.2)) == pytest.approx(0.01, abs=0.003)
    bad = labelled.to_dict()
    bad["throws"][0]["across"] = "sideways"
    with pytest.raises(LibraryFormatError, match="across"):
        ThrowLibrary.from_dict(bad)
    broken = online.library.to_dict()
    broken["meta"][META_KEY]["lateral"]["covariance_m2"] = [[1.0]]
    with pytest.raises(LibraryFormatError, match="sideways term"):
        OnlineLibrary.start(ThrowLibrary.from_dict(broken))
