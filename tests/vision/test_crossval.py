"""Leave-one-out cross-validation (the paper's Fig. 4 statistic)."""

import numpy as np
import pytest

from wiithrow.vision import leave_one_out, triangulate
from wiithrow.vision.crossval import leave_one_out_brute_force
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


def _scene(n, seed, outlier=False):
    cams = stereo_rig()
    rng = np.random.default_rng(seed)
    X = points_in_common_view(cams, n, rng)
    image = observe_all(cams, X, rng)
    image[1, 3] = np.nan  # a point only cam0 saw: not tested
    if outlier:
        image[0, 5] += 40.0
    return X, image


@pytest.mark.parametrize("method", ["normalized", "paper"])
def test_linear_methods_equal_refitting_without_each_point(method):
    """The closed forms of `dlt_loo` are exact: to round-off, what refitting n times gives."""
    X, image = _scene(40, 1)
    fast = leave_one_out(X, image, method)
    brute = leave_one_out_brute_force(X, image, method)
    assert np.array_equal(np.isnan(fast.errors), np.isnan(brute.errors)) and np.isnan(fast.errors[3])
    assert np.nanmax(np.abs(fast.errors - brute.errors) / brute.errors) < 1e-9


@pytest.mark.parametrize("method, outlier", [("refined", False), ("robust", True)])
def test_refined_methods_within_the_stated_bound_of_refitting(method, outlier):
    """One Gauss-Newton step from the full fit (30 points, past REFIT_BELOW): within 1 % of
    refitting per point and 0.1 % in the mean (dlt_loo's docstring); exact below 20 points."""
    for seed in (1, 2):
        X, image = _scene(30, seed, outlier)
        fast = leave_one_out(X, image, method)
        brute = leave_one_out_brute_force(X, image, method)
        assert np.array_equal(np.isnan(fast.errors), np.isnan(brute.errors))
        assert np.nanmax(np.abs(fast.errors - brute.errors) / brute.errors) < 0.01
        assert abs(fast.mean - brute.mean) < 0.001 * brute.mean
        assert np.nanmax(np.abs(fast.errors - brute.errors)) > 0  # the approximation is in use
    X, image = _scene(12, 3)
    small = leave_one_out(X, image, method)
    assert np.nanmax(np.abs(small.errors - leave_one_out_brute_force(X, image, method).errors)) < 1e-12


def test_six_points_cannot_be_cross_validated_and_say_so():
    cams = stereo_rig()
    rng = np.random.default_rng(4)
    X = points_in_common_view(cams, 7, rng)
    image = observe_all(cams, X, rng)
    loo = leave_one_out(X[:6], image[:, :6])
    assert loo.tested == 0 and np.isnan(loo.mean)
    assert "at least 7 points per camera" in loo.reason and "cam0 saw 6, cam1 saw 6" in loo.reason
    seven = leave_one_out(X, image)
    assert seven.tested == 7 and seven.reason == ""


def test_fits_given_are_used_and_not_refitted(monkeypatch):
    from wiithrow.vision import crossval, dlt

    X, image = _scene(30, 5)
    cameras = [dlt.calibrate(X[np.isfinite(image[c]).all(1)], image[c][np.isfinite(image[c]).all(1)]) for c in (0, 1)]
    monkeypatch.setattr(crossval, "calibrate", lambda *a, **k: pytest.fail("refitted a camera it was given"))
    assert leave_one_out(X, image, cameras=cameras).tested == 29
