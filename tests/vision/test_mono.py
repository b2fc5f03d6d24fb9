"""The mono method: right when the beacon pair faces the camera, wrong by ~1/cos(angle) otherwise."""

import numpy as np
import pytest

from wiithrow.vision import VisionError, WiimoteCamera, mono_position


def beacons(center, angle, distance=0.15):
    """Two beacons around `center`, their line turned by `angle` out of the image plane."""
    # the camera looks along +x: turning about z takes the line from y (parallel to the image)
    # towards x (along the optical axis)
    half = distance / 2 * np.array([np.sin(angle), np.cos(angle), 0.0])
    return center - half, center + half


def test_exact_when_parallel_to_image_plane():
    cam = WiimoteCamera.at([0, 0, 0], [1, 0, 0])
    center = np.array([1.2, 0.05, -0.03])
    a, b = beacons(center, 0.0)
    X = mono_position(cam.project(a[None]), cam.project(b[None]), 0.15, cam.K, cam.R, cam.t)
    assert np.allclose(X[0], center, atol=1e-9)


def test_depth_error_grows_like_one_over_cosine():
    cam = WiimoteCamera.at([0, 0, 0], [1, 0, 0])
    center = np.array([1.5, 0.0, 0.0])
    errors = []
    for angle in np.deg2rad([0, 20, 40, 60]):
        a, b = beacons(center, angle)
        X = mono_position(cam.project(a[None]), cam.project(b[None]), 0.15, cam.K, cam.R, cam.t)
        errors.append(X[0, 0] - center[0])
        assert X[0, 0] / center[0] == pytest.approx(1 / np.cos(angle), rel=0.01)
    assert errors[0] == pytest.approx(0, abs=1e-9)
    assert np.all(np.diff(errors) > 0)


def test_missing_beacon_gives_nan_and_bad_distance_is_refused():
    cam = WiimoteCamera.at([0, 0, 0], [1, 0, 0])
    X = mono_position([[np.nan, np.nan]], [[500.0, 380.0]], 0.15, cam.K)
    assert np.isnan(X).all()
    with pytest.raises(VisionError, match="positive"):
        mono_position([[0, 0]], [[1, 1]], 0.0, cam.K)
