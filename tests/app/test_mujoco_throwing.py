"""Throwing in the MuJoCo world, through the interfaces real hardware has: a reduced library
trained there from the rig's measurements of the landing marker, then throws at the same targets
with the learning and without it (the nominal model's exact solution)."""

from __future__ import annotations

import numpy as np
import pytest

from wiithrow.app.session import simulated_session
from wiithrow.app.studies.compensation import random_targets, throw_at
from wiithrow.app.throws.training import train_in_world
from wiithrow.app.worlds.mujoco.world import MujocoWorld
from wiithrow.throwing import training_targets

pytestmark = pytest.mark.slow


@pytest.fixture(scope="module")
def trained():
    """A MuJoCo session calibrated with the robot (the paper's procedure, 16 poses) and a 4 x 4
    library trained in it."""
    session = simulated_session(seed=4, world="mujoco", calibration="robot", poses=16, quiet=True)
    library = train_in_world(session.world, np.random.default_rng(5), targets=training_targets(nx=4, nz=4))
    session.use_library(library)
    return session, library


def test_the_labels_are_the_rigs_measurements_not_the_truth(trained):
    session, library = trained
    world = session.world
    assert isinstance(world, MujocoWorld) and world.lab.throws == len(library)
    # the operator's marker is off by 5 mm (sigma) and the rig measures it: labels differ from the truth
    last = world.lab.events
    assert last.marker is not None and last.touchdown is not None
    assert 0.0 < np.linalg.norm(last.marker[:2] - last.touchdown[:2]) < 0.03


def test_learned_throws_land_closer_than_the_nominal_models(trained):
    """16 targets: with 8 the medians' order was a coin toss once the 16-pose calibration measured
    the targets within 7-42 mm (the rig 15 cm further back; 22-113 mm before), which brought the
    nominal model's throws close (measured: learned median 8.3 mm, nominal 11.3 mm over 16; over 8,
    8.96 against 8.34 mm)."""
    session, _ = trained
    targets = random_targets(16, np.random.default_rng(11), margin=0.08)
    learned = throw_at(session, targets)
    session.use_analytic(True)
    try:
        analytic = throw_at(session, targets)
    finally:
        session.use_analytic(False)
    assert not np.isnan(learned).any() and not np.isnan(analytic).any()
    # stated bounds: a 16-throw library and a 16-pose calibration in a world the planner does not know
    assert np.median(learned) < 0.02 and learned.max() < 0.05, learned
    assert np.median(learned) < np.median(analytic), (learned, analytic)
    record = session.history[-1]
    assert np.isfinite(record.execution.release_tracking_m) and record.execution.spin is not None


def test_learning_compensates_a_calibration_error_in_mujoco():
    """The compensation experiment (`app/studies/compensation.py`) in the world the planner does not
    know: a 3 % / 1 degree wrong calibration, trained through it and not."""
    from wiithrow.app.studies.compensation import run_compensation

    result = run_compensation(targets=6, seed=3, world="mujoco", poses=16)
    median = {case: float(np.nanmedian(e)) for case, e in result.errors.items()}
    assert all(np.isnan(e).sum() <= 1 for e in result.errors.values())
    # stated bounds: learning through the wrong calibration lands about as well as with the right one,
    # and far better than the right library aimed through the wrong calibration
    assert median["compensated"] < 1.5 * median["true"] + 0.005, median
    assert median["uncompensated"] > 2 * median["compensated"], median
