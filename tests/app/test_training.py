"""Training in the world: labels are the rig's measurements of where the balls landed."""

import numpy as np

from wiithrow.app.session import simulated_session
from wiithrow.app.throws.training import train_in_world
from wiithrow.throwing import leave_one_out_error, training_targets
from wiithrow.throwing.library import Area


def test_a_small_library_trained_through_the_rig():
    session = simulated_session(seed=7, calibration="true")
    targets = training_targets(Area((1.1, 1.5), (0.0, 0.3)), 3, 3)
    seen = []
    library = train_in_world(
        session.world,
        np.random.default_rng(0),
        targets=targets,
        on_throw=lambda target, measured: seen.append((target, measured)),
    )
    assert len(library.throws) == 9 and len(seen) == 9
    for throw in library.throws:
        # the operator aims (with 1 cm placement jitter); noise moves the landing by millimetres
        assert np.linalg.norm(throw.landing - throw.target) < 0.01
    assert leave_one_out_error(library).median < 0.02
