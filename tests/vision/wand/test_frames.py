"""The frame of a wand calibration: an L-frame's three LEDs, or the robot's hand LED at six poses."""

import numpy as np
import pytest

from tests.helpers.wand_rigs import wide_pair
from wiithrow.vision.errors import CalibrationError, WandLengthError
from wiithrow.vision.geometry import rodrigues
from wiithrow.vision.rig import observe_all
from wiithrow.vision.wand.calibrate import calibrate_wand
from wiithrow.vision.wand.frames import fit_rigid, lframe_fit, robot_fit, transform_calibration
from wiithrow.vision.wand.scale import check_scale
from wiithrow.vision.wand.waver import wave_wand


def test_a_rigid_motion_comes_back_with_zero_residual_and_unit_scale():
    rng = np.random.default_rng(0)
    R, t = rodrigues([0.3, -0.2, 0.9]), np.array([0.5, -1.0, 2.0])
    old = rng.normal(size=(10, 3))
    fit = fit_rigid(old, old @ R.T + t, "new")
    assert np.allclose(fit.R, R) and np.allclose(fit.t, t)
    assert fit.rms_m < 1e-12 and fit.scale == pytest.approx(1.0)
    assert fit_rigid(old, 1.1 * (old @ R.T + t), "new").scale == pytest.approx(1.1)


def test_the_lframe_sets_origin_and_axes_whatever_the_leds_order():
    R, t = rodrigues([0.1, 0.4, -0.3]), np.array([0.2, 0.1, 1.5])
    nominal = np.array([[0.0, 0.0, 0.0], [0.4, 0.0, 0.0], [0.0, 0.25, 0.0]])
    measured = (nominal - t) @ R  # where the rig sees them: X_old = R^T (X_new - t)
    fit = lframe_fit(measured[[2, 0, 1]])
    assert np.allclose(fit.R, R) and np.allclose(fit.t, t) and fit.rms_m < 1e-12


def test_an_lframe_with_equal_arms_is_refused():
    with pytest.raises(CalibrationError, match="arms measure"):
        lframe_fit([[0, 0, 0], [0.3, 0, 0], [0, 0.3, 0]])


@pytest.fixture(scope="module")
def wand_rig():
    rig = wide_pair()
    observations, _ = wave_wand(rig.cameras, 20, np.random.default_rng(40), shuffle=True, depth_m=rig.depth_m)
    return rig, observations


def robot_poses(rig, count, rng):
    """The hand LED at `count` poses: its positions in the rig's frame (the robot's, here) and
    the pixels of it averaged over 10 frames, as the robot calibration takes them."""
    positions = rig.points(count, rng)
    image = np.mean([observe_all(rig.cameras, positions, rng) for _ in range(10)], axis=0)
    return positions, image


def test_six_arm_poses_put_the_wand_calibration_in_the_robots_frame(wand_rig):
    rig, observations = wand_rig
    result = calibrate_wand(observations, 0.3)
    positions, image = robot_poses(rig, 6, np.random.default_rng(41))
    fit = robot_fit(result.calibration.triangulate(image).points, positions)
    assert fit.name == "link1" and fit.rms_m < 0.002 and abs(fit.scale - 1) < 0.005
    moved = transform_calibration(result.calibration, fit)
    assert moved.frame == "link1" and moved.meta["frame_fit"]["points"] == 6
    test_points = rig.points(200, np.random.default_rng(42))
    X = moved.triangulate(observe_all(rig.cameras, test_points, np.random.default_rng(43))).points
    assert np.nanmean(np.linalg.norm(X - test_points, axis=1)) < 0.005  # in the robot's frame, unaligned
    # a point's pixels do not change with the frame
    seen = moved.cameras[0].project(test_points[:5])
    before = result.calibration.cameras[0].project((test_points[:5] - fit.t) @ fit.R)
    assert np.allclose(seen, before)


def test_a_wrong_wand_length_shows_against_the_robot(wand_rig):
    rig, observations = wand_rig
    result = calibrate_wand(observations, 0.36)  # the wand is 0.30 m
    positions, image = robot_poses(rig, 8, np.random.default_rng(44))
    fit = robot_fit(result.calibration.triangulate(image).points, positions)
    assert fit.scale == pytest.approx(0.30 / 0.36, rel=0.005)
    with pytest.raises(WandLengthError, match="a wand of 0.300 m"):
        check_scale(fit.scale, 0.36, "the robot")


def test_fewer_than_six_poses_are_refused():
    with pytest.raises(CalibrationError, match="6 or more poses"):
        robot_fit(np.zeros((5, 3)), np.zeros((5, 3)))
