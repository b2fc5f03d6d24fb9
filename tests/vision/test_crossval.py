"""Leave-one-out cross-validation (the paper's Fig. 4 statistic)."""

import numpy as np

from wiithrow.vision import leave_one_out, triangulate
from wiithrow.vision.rig import observe_all, points_in_common_view, stereo_rig


def test_loo_error_estimates_the_error_on_new_points():
    cams = stereo_rig()
    ratios = []
    for seed in range(4):
        rng = np.random.default_rng(seed)
        X = points_in_common_view(cams, 30, rng)
        image = observe_all(cams, X, rng)
        loo = leave_one_out(X, image)
        assert np.isfinite(loo.errors).all()
        # a held-out point is a new point: its error compares with the error of true cameras
        # on the same pixels, a bit larger (the calibration's own error comes on top)
        true = np.linalg.norm(triangulate(np.stack([c.P for c in cams]), image).points - X, axis=1).mean()
        ratios.append(loo.mean / true)
    assert 1.0 < np.mean(ratios) < 1.6, ratios


def test_more_points_give_a_smaller_loo_error():
    cams = stereo_rig()
    small, large = [], []
    for seed in range(6):
        rng = np.random.default_rng(seed)
        X = points_in_common_view(cams, 60, rng)
        image = observe_all(cams, X, rng)
        small.append(leave_one_out(X[:8], image[:, :8]).mean)
        large.append(leave_one_out(X, image).mean)
    assert np.mean(large) < 0.5 * np.mean(small)


def test_unseen_points_are_not_tested_and_worst_points_are_found():
    cams = stereo_rig()
    rng = np.random.default_rng(9)
    X = points_in_common_view(cams, 20, rng)
    image = observe_all(cams, X, rng)
    image[1, 3] = np.nan
    image[0, 5] += 40.0  # a badly measured point
    loo = leave_one_out(X, image)
    assert np.isnan(loo.errors[3])
    assert loo.worst(1)[0] == 5
    assert np.isfinite(loo.mean)
