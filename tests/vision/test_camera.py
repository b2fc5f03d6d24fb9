"""The Wiimote camera model: projection, what the remote reports, and what it drops."""

import numpy as np
import pytest

from wiithrow.vision.camera import MAX_BLOBS, WiimoteCamera, look_at_rotation, pitched_forward


def camera() -> WiimoteCamera:
    return WiimoteCamera.at([0.0, 0.0, 0.0], [1.0, 0.0, 0.0])


def test_projection_matches_pinhole_formula():
    cam = camera()
    # looking along +x with z up: image x is -y of the frame, image y is -z
    X = np.array([[2.0, -0.1, 0.05]])
    u, v = cam.project(X)[0]
    assert u == pytest.approx(512 + 1300 * 0.1 / 2.0)
    assert v == pytest.approx(384 - 1300 * 0.05 / 2.0)


def test_rotation_is_proper_and_axes_follow_convention():
    R = look_at_rotation(pitched_forward(np.deg2rad(15)))
    assert np.allclose(R @ R.T, np.eye(3), atol=1e-12)
    assert np.linalg.det(R) == pytest.approx(1.0)
    # optical axis pitched down: its z component is negative
    assert R[2, 2] == pytest.approx(-np.sin(np.deg2rad(15)))
    with pytest.raises(ValueError, match="parallel"):
        look_at_rotation([0, 0, 1])


def test_points_behind_or_outside_are_missing():
    cam = camera()
    X = np.array([[-1.0, 0.0, 0.0], [1.0, 5.0, 0.0], [1.0, 0.0, 0.0]])
    obs = cam.observe(X, np.random.default_rng(0), sigma_px=0.0)
    assert np.isnan(obs[0]).all() and np.isnan(obs[1]).all()
    assert np.array_equal(obs[2], [512.0, 384.0])


def test_reports_integers_with_the_stated_noise():
    cam = camera()
    rng = np.random.default_rng(1)
    X = np.tile([[1.0, 0.0123, 0.0071]], (20000, 1))
    obs = cam.observe(X, rng, sigma_px=0.5, max_blobs=None)
    assert np.all(obs == np.rint(obs))
    ideal = cam.project(X[:1])[0]
    # noise sigma 0.5 px then rounding: std of the reported value is sqrt(0.25 + ~1/12) ~ 0.58
    std = obs.std(axis=0)
    assert np.all((std > 0.50) & (std < 0.66)), std
    assert np.allclose(obs.mean(axis=0), ideal, atol=0.03)


def test_at_most_four_blobs_first_ones_kept():
    cam = camera()
    X = np.column_stack([np.full(6, 1.0), np.linspace(-0.1, 0.1, 6), np.zeros(6)])
    obs = cam.observe(X, np.random.default_rng(0), sigma_px=0.0)
    seen = np.isfinite(obs).all(axis=1)
    assert seen.sum() == MAX_BLOBS
    assert seen[:4].all() and not seen[4:].any()


def test_dropout_rate_is_respected():
    cam = camera()
    X = np.tile([[1.0, 0.0, 0.0]], (10000, 1))
    obs = cam.observe(X, np.random.default_rng(2), dropout=0.2, max_blobs=None)
    assert np.isnan(obs[:, 0]).mean() == pytest.approx(0.2, abs=0.015)


def test_blob_size_shrinks_with_depth_and_stays_in_range():
    cam = camera()
    sizes = cam.blob_sizes(np.array([[0.2, 0, 0], [1.0, 0, 0], [3.0, 0, 0], [-1.0, 0, 0]]))
    assert sizes[0] >= sizes[1] >= sizes[2] >= 1
    assert sizes[0] <= 15 and sizes[3] == 0


def test_same_seed_same_observations():
    cam = camera()
    X = np.random.default_rng(3).uniform([0.5, -0.2, -0.2], [1.5, 0.2, 0.2], (50, 3))
    a = cam.observe(X, np.random.default_rng(7), max_blobs=None)
    b = cam.observe(X, np.random.default_rng(7), max_blobs=None)
    assert np.array_equal(a, b, equal_nan=True)


def _observe_step_by_step(cam: WiimoteCamera, X: np.ndarray, rng: np.random.Generator, dropout: float, max_blobs):
    """What a remote reports, spelled out from the model's pieces (`project`, `in_view`) and the
    size formula: the reference `observe_sized`'s one pass must equal."""
    uv = np.rint(cam.project(X) + rng.normal(0.0, 0.5, size=(len(X), 2)))
    seen = cam.in_view(uv)
    if dropout > 0:
        seen &= rng.random(len(X)) >= dropout
    if max_blobs is not None:
        seen &= np.cumsum(seen) <= max_blobs
    uv[~seen] = np.nan
    depth = cam.to_camera(X)[:, 2]
    with np.errstate(divide="ignore", invalid="ignore"):
        sizes = np.where(depth > 1e-9, np.clip(np.rint(cam.blob_size_at_1m / depth), 1, 15), 0).astype(np.int64)
    return uv, sizes


@pytest.mark.parametrize(("dropout", "max_blobs"), [(0.0, None), (0.3, MAX_BLOBS)])
def test_one_pass_observation_equals_the_step_by_step_one(dropout, max_blobs):
    # 2000 points around a pitched camera: in view, off the sensor, behind it, in its focal plane
    cam = WiimoteCamera.at([0.1, -0.2, 0.3], pitched_forward(np.deg2rad(20), 0.3))
    X = np.random.default_rng(11).uniform([-1.0, -1.5, -1.0], [3.0, 1.5, 1.5], (2000, 3))
    X[:5] = cam.center  # depth 0 exactly
    uv, sizes = cam.observe_sized(X, np.random.default_rng(5), dropout=dropout, max_blobs=max_blobs)
    ref_uv, ref_sizes = _observe_step_by_step(cam, X, np.random.default_rng(5), dropout, max_blobs)
    n_seen = np.isfinite(uv[:, 0]).sum()
    assert n_seen == MAX_BLOBS if max_blobs else 200 < n_seen < 1800  # seen and unseen both well represented
    assert np.array_equal(uv, ref_uv, equal_nan=True)
    assert np.array_equal(sizes, ref_sizes)
    assert np.array_equal(
        cam.observe(X, np.random.default_rng(5), dropout=dropout, max_blobs=max_blobs), uv, equal_nan=True
    )
    assert np.array_equal(cam.blob_sizes(X), sizes)


@pytest.mark.parametrize(
    ("sigma_px", "dropout", "max_blobs"), [(0.5, 0.0, None), (0.5, 0.3, MAX_BLOBS), (0.0, 0.0, None)]
)
def test_plain_float_observation_gives_the_same_pixels_and_sizes(sigma_px, dropout, max_blobs):
    # 20 x 2000 points (in view, off the sensor, behind, in the focal plane): `observe_few`'s integer
    # pixels and sizes equal `observe_sized`'s on every one (measured: 0 differences in 1.2 million)
    cam = WiimoteCamera.at([0.1, -0.2, 0.3], pitched_forward(np.deg2rad(20), 0.3))
    n_seen = 0
    for seed in range(20):
        X = np.random.default_rng(seed).uniform([-1.0, -1.5, -1.0], [3.0, 1.5, 1.5], (2000, 3))
        X[:5] = cam.center
        kw = {"sigma_px": sigma_px, "dropout": dropout, "max_blobs": max_blobs}
        uv, sizes = cam.observe_sized(X, np.random.default_rng(seed), **kw)
        pixels, few_sizes = cam.observe_few(X.tolist(), np.random.default_rng(seed), **kw)
        assert pixels == [None if u != u else (int(u), int(v)) for u, v in uv.tolist()]
        assert few_sizes == sizes.tolist()
        n_seen += sum(p is not None for p in pixels)
    assert n_seen == 20 * MAX_BLOBS if max_blobs else 4000 < n_seen < 36000


def test_plain_float_observation_of_a_skewed_camera_uses_the_general_formulas():
    K = np.array([[1300.0, 40.0, 512.0], [0.0, 1300.0, 384.0], [0.0, 0.0, 1.0]])
    cam = WiimoteCamera(K=K, R=np.eye(3), t=np.zeros(3))
    X = np.random.default_rng(2).uniform([-0.2, -0.2, 0.5], [0.2, 0.2, 1.5], (200, 3))
    uv, sizes = cam.observe_sized(X, np.random.default_rng(4), max_blobs=None)
    pixels, few_sizes = cam.observe_few(X.tolist(), np.random.default_rng(4), max_blobs=None)
    assert pixels == [None if u != u else (int(u), int(v)) for u, v in uv.tolist()]
    assert few_sizes == sizes.tolist() and sum(p is not None for p in pixels) > 100
