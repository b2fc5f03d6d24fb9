"""The live path with four remotes: the synchroniser, correspondence and tracker on a rig of four
unsynchronised remotes placed as the settings place them."""

import numpy as np

from tests.vision.test_tracker import identities, track
from wiithrow.app.rig.moving_markers import crossing_paths
from wiithrow.app.settings import Settings
from wiithrow.app.worlds import nominal_cameras


def test_four_crossing_markers_keep_their_ids_with_four_remotes():
    """Issue 15: the live path with four remotes (placed as the settings place them, turned towards
    a point ahead, unsynchronised), four markers crossing: no id ever swaps."""
    cams = nominal_cameras(Settings().with_cameras(4).rig)
    frames, truths = track(cams, crossing_paths, 6.0, np.random.default_rng(5), offsets=[0.0, 0.0037, 0.0061, 0.0083])
    pairs = identities(frames[5:], truths[5:])
    ids = {}
    for marker_id, truth_index in pairs:
        assert ids.setdefault(marker_id, truth_index) == truth_index, f"marker {marker_id} swapped"
    assert sorted(ids.values()) == [0, 1, 2, 3] and len(ids) == 4
    assert max(int(n) for f in frames[5:] for n in f.n_views) == 4
