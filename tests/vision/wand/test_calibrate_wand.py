"""Wand calibration of simulated rigs of 2, 3 and 4 remotes, none of them the demo's.

Every rig is waved at for 30 s (0.5 px noise, integer pixels, drop-outs, unsynchronised remotes,
the two dots in random order in every camera and frame). The goal of issue 15 is a 3D error of new
points within 1.25 times what the robot calibration reaches; the robot's reaches the true cameras'
(1.003 times, docs/calibration.md), so here the wand calibration is held to the true cameras on
the same noisy pixels, after aligning the frame (the wand's frame is the first camera's, which
the true cameras only know up to their own error).
"""

import numpy as np
import pytest

from tests.helpers.wand_rigs import arc_of_three, four_corners, wide_pair
from wiithrow.vision import StereoCalibration
from wiithrow.vision.errors import DegenerateMotionError, TooFewFramesError, WandLengthError, WandNotSeenError
from wiithrow.vision.rig import observe_all
from wiithrow.vision.triangulation import triangulate
from wiithrow.vision.wand.calibrate import calibrate_wand
from wiithrow.vision.wand.frames import fit_rigid
from wiithrow.vision.wand.observations import WandObservations
from wiithrow.vision.wand.quality import wand_lengths
from wiithrow.vision.wand.waver import wave_wand

RIGS = {"wide pair": wide_pair, "arc of three": arc_of_three, "four corners": four_corners}
WAND_M = 0.3


def aligned_error(Ps, cameras, test_points, rng):
    """Mean 3D error (m) of test points triangulated by Ps from one noisy frame, after the rigid
    motion that best aligns them with the truth; and the true cameras' on the same pixels."""
    image = observe_all(cameras, test_points, rng)
    out = []
    for P in (Ps, np.stack([c.P for c in cameras])):
        X = triangulate(P, image).points
        seen = np.isfinite(X).all(axis=1)
        out.append(float(np.mean(fit_rigid(X[seen], test_points[seen], "truth").residuals_m)))
    return out


@pytest.fixture(scope="module", params=list(RIGS))
def calibrated(request):
    rig = RIGS[request.param]()
    rng = np.random.default_rng(20)
    observations, _ = wave_wand(rig.cameras, 30, rng, shuffle=True, dropout=0.02, depth_m=rig.depth_m)
    return rig, observations, calibrate_wand(observations, WAND_M, rng=np.random.default_rng(21))


def test_new_points_are_as_accurate_as_with_the_true_cameras(calibrated):
    rig, _, result = calibrated
    test_points = rig.points(400, np.random.default_rng(22))
    wand, true = aligned_error(result.calibration.Ps, rig.cameras, test_points, np.random.default_rng(23))
    assert wand <= 1.10 * true, (rig.name, wand, true)  # measured 1.003-1.009


def test_intrinsics_come_out_of_the_nominal_guess(calibrated):
    rig, _, result = calibrated
    for fitted, camera in zip(result.calibration.cameras, rig.cameras):
        K = fitted.decompose().K
        assert abs(K[0, 0] / camera.K[0, 0] - 1) < 0.01  # focal length within 1 %
        assert np.linalg.norm(K[:2, 2] - camera.K[:2, 2]) < 8.0  # principal point within 8 px


def test_quality_figures_describe_the_fit(calibrated):
    rig, observations, result = calibrated
    q = result.quality
    assert all(0.3 < r < 0.8 for r in q.reprojection_rms_px)  # 0.5 px noise, rounded
    assert abs(q.length_mean_m - WAND_M) < 0.001
    true_lengths, _ = wand_lengths(np.stack([c.P for c in rig.cameras]), result.labels.pixels)
    used = result.labels.usable & ~result.heldout
    true_score = 100 * np.nanstd(true_lengths[used]) / np.nanmean(true_lengths[used])
    assert q.wand_score_percent < 1.1 * true_score + 0.02  # the true cameras' own spread
    assert q.heldout_frames > 0 and q.heldout_length_rms_m < 0.003
    assert q.frames_fitted <= 1000 and q.frames_usable > 0.6 * observations.frames
    assert q.coverage.shape == (len(rig.cameras), 6, 8) and q.warnings == ()


def test_the_result_is_an_ordinary_calibration_file(calibrated, tmp_path):
    rig, _, result = calibrated
    calibration = result.calibration
    assert calibration.frame == "cam0" and len(calibration.cameras) == len(rig.cameras)
    back = StereoCalibration.load(calibration.save(tmp_path / "wand.json"))
    assert np.allclose(back.Ps, calibration.Ps) and back.meta["quality"]["wand_score_percent"] > 0
    assert all(c.method == "wand" and 0 < len(c.world) <= 200 for c in back.cameras)


@pytest.fixture(scope="module")
def pair_recording():
    rig = wide_pair()
    observations, _ = wave_wand(rig.cameras, 20, np.random.default_rng(30), shuffle=True, depth_m=rig.depth_m)
    return rig, observations


def test_missing_and_single_dots_still_calibrate(pair_recording):
    rig, observations = pair_recording
    rng = np.random.default_rng(31)
    pixels = observations.pixels.copy()
    gone = rng.random(pixels.shape[:3]) < 0.15  # 15 % of the dots missing: many frames with one dot
    pixels[gone] = np.nan
    lonely = np.isnan(pixels[:, :, 0, 0]) & np.isfinite(pixels[:, :, 1, 0])
    pixels[lonely, 0], pixels[lonely, 1] = pixels[lonely, 1], np.nan  # a single dot comes first
    result = calibrate_wand(WandObservations(observations.t, pixels), WAND_M)
    test_points = rig.points(300, np.random.default_rng(32))
    wand, true = aligned_error(result.calibration.Ps, rig.cameras, test_points, np.random.default_rng(33))
    assert wand <= 1.10 * true


def test_a_length_in_the_wrong_unit_is_refused(pair_recording):
    _, observations = pair_recording
    with pytest.raises(WandLengthError, match="where a Wiimote cannot see it"):
        calibrate_wand(observations, 300.0)  # millimetres


def test_leds_too_close_to_tell_apart_are_refused():
    rig = wide_pair()
    observations, _ = wave_wand(rig.cameras, 5, np.random.default_rng(34), wand_length_m=0.015, depth_m=rig.depth_m)
    with pytest.raises(WandLengthError, match="px apart"):
        calibrate_wand(observations, 0.015)


def test_too_short_a_recording_is_refused():
    rig = wide_pair()
    observations, _ = wave_wand(rig.cameras, 1.5, np.random.default_rng(35), depth_m=rig.depth_m)
    with pytest.raises(TooFewFramesError, match="record for longer"):
        calibrate_wand(observations, WAND_M)


def test_a_camera_that_never_saw_both_leds_is_named():
    rig = arc_of_three()
    observations, _ = wave_wand(rig.cameras, 5, np.random.default_rng(36), depth_m=rig.depth_m)
    pixels = observations.pixels.copy()
    pixels[2, :, 1] = np.nan
    with pytest.raises(WandNotSeenError, match="cam2 never saw both LEDs"):
        calibrate_wand(WandObservations(observations.t, pixels), WAND_M)


def test_a_wand_that_only_translated_is_refused():
    rig = wide_pair()
    observations, _ = wave_wand(rig.cameras, 10, np.random.default_rng(37), turn=False, depth_m=rig.depth_m)
    with pytest.raises(DegenerateMotionError, match="only translated"):
        calibrate_wand(observations, WAND_M)


def test_a_camera_blinded_by_another_ir_source_says_so():
    rig = wide_pair()
    cam0 = rig.cameras[0]
    lamp = cam0.center + 0.3 * cam0.R[2]  # 0.3 m in front of cam0 only
    observations, _ = wave_wand(rig.cameras, 5, np.random.default_rng(38), stray=lamp, depth_m=rig.depth_m)
    assert observations.crowded[0] > 0.8 * observations.frames and observations.crowded[1] == 0
    with pytest.raises(TooFewFramesError, match=r"cam0 saw more than two dots in \d+ of \d+ frames: switch off"):
        calibrate_wand(observations, WAND_M)
