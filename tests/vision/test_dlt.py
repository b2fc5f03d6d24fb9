"""DLT calibration of one camera: every method, the decomposition, and bad input."""

import numpy as np
import pytest

from tests.helpers.vgg_house import load_house
from wiithrow.vision import CalibrationError, calibrate
from wiithrow.vision.camera import WiimoteCamera, pitched_forward
from wiithrow.vision.dlt import METHODS
from wiithrow.vision.geometry import decompose, reprojection_errors
from wiithrow.vision.rig import points_in_common_view


def scene(seed=0, n=30, sigma=0.5):
    rng = np.random.default_rng(seed)
    cam = WiimoteCamera.at([0.0, 0.125, 0.35], pitched_forward(np.deg2rad(5)), focal_px=1300)
    X = points_in_common_view([cam], n, rng)
    x = cam.observe(X, rng, sigma_px=sigma, max_blobs=None)
    return cam, X, x


@pytest.mark.parametrize("method", METHODS)
def test_noise_free_data_gives_the_true_camera(method):
    cam, X, _ = scene()
    x = cam.project(X)
    fit = calibrate(X, x, method)
    assert fit.rms_px < 1e-6
    d = fit.decompose()
    assert np.allclose(d.K, cam.K, rtol=1e-6, atol=1e-4)
    assert np.allclose(d.R, cam.R, atol=1e-8)
    assert np.allclose(d.center, cam.center, atol=1e-8)
    assert not d.mirrored


@pytest.mark.parametrize("method", METHODS)
def test_noisy_fit_reaches_the_noise_floor(method):
    cam, X, x = scene(seed=1)
    fit = calibrate(X, x, method)
    # sigma 0.5 px + rounding: per-point error ~0.58 px per axis, ~0.8 px in 2D; fit absorbs 11 dof
    assert 0.4 < fit.rms_px < 1.0
    assert np.linalg.norm(fit.decompose().center - cam.center) < 0.03


def test_refined_never_worse_than_normalized_and_is_the_ml_fit():
    for seed in range(5):
        _, X, x = scene(seed=seed)
        normalized = calibrate(X, x, "normalized")
        refined = calibrate(X, x, "refined")
        assert refined.rms_px <= normalized.rms_px + 1e-9


def test_robust_recovers_true_camera_with_20_percent_gross_outliers():
    cam, X, x = scene(seed=4, n=40)
    rng = np.random.default_rng(5)
    bad = rng.choice(len(X), 8, replace=False)
    x = x.copy()
    x[bad] += rng.uniform(25, 80, (8, 2)) * rng.choice([-1, 1], (8, 2))
    assert np.all(np.linalg.norm(x[bad] - cam.project(X[bad]), axis=1) > 20)
    fit = calibrate(X, x, "robust")
    assert set(np.flatnonzero(~fit.inliers)) == set(bad)
    # over the whole volume the robust camera is as close to the true one as a fit that was told
    # which points are good (the best any method can do with these 32 noisy points)
    test = points_in_common_view([cam], 500, rng)
    clean = calibrate(np.delete(X, bad, axis=0), np.delete(x, bad, axis=0), "refined")
    robust_error = np.linalg.norm(fit.project(test) - cam.project(test), axis=1).mean()
    clean_error = np.linalg.norm(clean.project(test) - cam.project(test), axis=1).mean()
    assert robust_error <= 1.05 * clean_error + 1e-9
    assert robust_error < 0.6
    # while a plain fit is pulled off (or refused as meaningless)
    try:
        plain = calibrate(X, x, "refined")
        assert np.max(np.linalg.norm(plain.project(test) - cam.project(test), axis=1)) > 3.0
    except CalibrationError as exc:
        assert "px" in str(exc)


def test_mirrored_image_is_recognised():
    cam, X, _ = scene()
    x = cam.project(X)
    x[:, 0] = 1023 - x[:, 0]  # a remote whose x axis runs the other way
    fit = calibrate(X, x)
    d = fit.decompose()
    assert d.mirrored and d.K[0, 0] < 0 and d.K[1, 1] > 0
    assert np.linalg.det(d.R) == pytest.approx(1.0)
    assert np.allclose(d.center, cam.center, atol=1e-6)
    depth = (X @ d.R.T + d.t)[:, 2]
    assert np.all(depth > 0)


def test_decomposition_recomposes_P():
    _, X, x = scene(seed=2)
    fit = calibrate(X, x)
    d = decompose(fit.P)
    P = d.K @ np.hstack([d.R, d.t[:, None]])
    assert np.allclose(P / np.linalg.norm(P), fit.P / np.linalg.norm(fit.P), atol=1e-12)


def test_paper_method_is_eq_17_18_exactly():
    """p34 = 1 and the least-squares solution of the 11 remaining unknowns."""
    _, X, x = scene(seed=3)
    fit = calibrate(X, x, "paper")
    P = fit.P / fit.P[2, 3]
    # the normal equations of A a = b hold at the solution: A^T (A a - b) = 0
    rows = []
    rhs = []
    for (px, py, pz), (u, v) in zip(X, x):
        rows.append([px, py, pz, 1, 0, 0, 0, 0, -u * px, -u * py, -u * pz])
        rows.append([0, 0, 0, 0, px, py, pz, 1, -v * px, -v * py, -v * pz])
        rhs += [u, v]
    A, b = np.array(rows), np.array(rhs)
    a = P.ravel()[:11]
    assert np.allclose(A.T @ (A @ a - b), 0, atol=1e-6 * np.abs(A.T @ b).max())


@pytest.mark.parametrize(
    "mutate, message",
    [
        (lambda X, x: (X[:5], x[:5]), "at least 6"),
        (lambda X, x: (X, x[:-1]), "world points but"),
        (lambda X, x: (X[:, :2], x), r"shape \(N, 3\)"),
        (lambda X, x: (X, np.where(np.arange(len(x))[:, None] == 3, np.nan, x)), "NaN"),
        (lambda X, x: (np.vstack([X, X[:1]]), np.vstack([x, x[:1]])), "duplicated"),
        (lambda X, x: (X * [1, 1, 0], x), "coplanar"),
        (lambda X, x: (np.outer(np.linspace(0.5, 1, len(X)), [1, 0.2, 0.1]), x), "collinear"),
        (lambda X, x: (X, np.random.default_rng(0).permutation(x)), "do not describe one camera"),
    ],
)
def test_bad_input_is_refused_with_a_specific_message(mutate, message):
    _, X, x = scene()
    with pytest.raises(CalibrationError, match=message):
        calibrate(*mutate(X, x))


def test_unknown_method():
    _, X, x = scene()
    with pytest.raises(CalibrationError, match="unknown calibration method"):
        calibrate(X, x, "magic")


def test_paper_method_fails_where_the_origin_is_in_the_focal_plane():
    """The documented pitfall: p34 is the origin's depth, a34 = 1 cannot represent 0."""
    rng = np.random.default_rng(0)
    cam = WiimoteCamera.at([0.0, 0.0, 0.0], [1.0, 0.0, 0.0])  # origin at the optical centre
    X = points_in_common_view([cam], 30, rng)
    x = cam.observe(X, rng, max_blobs=None)
    normalized = calibrate(X, x, "normalized")
    assert normalized.rms_px < 1.0
    try:
        paper = calibrate(X, x, "paper")
        assert paper.rms_px > 3 * normalized.rms_px
    except CalibrationError as exc:
        assert "focal plane" in str(exc) or "behind" in str(exc)


def test_real_data_vgg_house_matches_the_given_cameras():
    """Oxford house: per view, refined and normalized within 0.01 px of the given P's RMS."""
    house = load_house()
    for view in range(len(house.Ps)):
        seen = np.isfinite(house.image[view]).all(axis=1)
        X, x = house.points[seen], house.image[view, seen]
        given = np.sqrt(np.mean(reprojection_errors(house.Ps[view], X, x) ** 2))
        for method in ("refined", "normalized"):
            fit = calibrate(X, x, method)
            assert fit.rms_px <= given + 0.01, (view, method, fit.rms_px, given)


def test_real_data_paper_method_fails_on_views_0_and_1():
    house = load_house()
    for view in (0, 1):
        seen = np.isfinite(house.image[view]).all(axis=1)
        X, x = house.points[seen], house.image[view, seen]
        given = np.sqrt(np.mean(reprojection_errors(house.Ps[view], X, x) ** 2))
        fit = calibrate(X, x, "paper", max_rms_px=1e9)
        assert fit.rms_px > given + 5.0


def test_normalized_solve_needs_memory_linear_in_the_points():
    """The 12 x 12 normal equations, not an SVD of the 2N x 12 system (whose full U alone is
    (2N)^2 doubles: 288 MB at N = 3,000; 4.2 GB at 8,000)."""
    import tracemalloc

    cam = WiimoteCamera.at([0.0, 0.0, 0.0], [1.0, 0.0, 0.0])
    rng = np.random.default_rng(0)
    X = points_in_common_view([cam], 3000, rng)
    x = cam.observe(X, rng, max_blobs=None)
    tracemalloc.start()
    try:
        calibrate(X, x, "normalized")
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert peak < 5e6, f"{peak / 1e6:.1f} MB for 3,000 points"
