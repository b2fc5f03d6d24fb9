"""`wiithrow bench wand`: a wand calibration against the same rig's robot calibration.

For the default rig of two remotes and for four remotes (both placed by the settings:
`Settings.with_cameras`), on the simulated world (0.5 px noise, integer pixels, the remotes'
HID bytes, unsynchronised remotes):

* a person waves a 0.3 m wand for 60 s (`SimWorld.wave_wand`), recorded through the live path
  (`capture_wand`) and fitted (`calibrate_wand`, timed: `fit_s`, of which `bundle_s` is the
  bundle adjustment);
* the arm calibrates the same rig with 30 poses (`calibrate_with_robot`, as `calibrate --robot`);
* test points: 300 of the arm's pose candidates (the volume the arm reaches and the rig sees,
  where the robot calibration is meant to be used), one noisy frame each. Each calibration
  triangulates the same pixels; the error is the mean distance to the truth after the rigid motion
  that best aligns the points (the wand calibration's frame is its first camera's, the robot's is
  link1: this compares the shape of the measurements, not the choice of frame). `ratio_to_robot`
  = wand error / robot error (goal <= 1.25); the true cameras' error on the same pixels is the
  floor both approach;
* the wand score (100 std/mean of the triangulated wand length, goal <= 0.5 % at 0.5 px), and the
  true cameras' own score on the same frames: what the rig's geometry allows (the wand's
  depth error grows as distance^2 / baseline), whatever the calibration.

Goal for the fit: `fit_s` <= 5 s for 60 s of 100 Hz data from 2 cameras.
"""

from __future__ import annotations

import time
from typing import Any

import numpy as np
from numpy.typing import NDArray

from wiithrow.app.calibration.poses import sample_candidates
from wiithrow.app.calibration.robot import calibrate_with_robot
from wiithrow.app.calibration.wand_capture import capture_wand
from wiithrow.app.settings import Settings
from wiithrow.app.worlds import SimWorld, nominal_cameras
from wiithrow.vision import triangulate
from wiithrow.vision.wand.calibrate import calibrate_wand
from wiithrow.vision.wand.frames import fit_rigid
from wiithrow.vision.wand.quality import wand_lengths

WAND_M = 0.3
TEST_POINTS = 300


def aligned_error_m(Ps: NDArray[np.float64], image: NDArray[np.float64], truth: NDArray[np.float64]) -> float:
    """Mean 3D error (m) of the points Ps triangulate from `image` (C, N, 2), after the rigid motion
    that best aligns them with `truth` (N, 3)."""
    X = triangulate(Ps, image).points
    seen = np.isfinite(X).all(axis=1)
    return float(np.mean(fit_rigid(X[seen], truth[seen], "truth").residuals_m))


def measure(remotes: int, seconds: float, poses: int, seed: int = 0) -> dict[str, Any]:
    """The figures of one rig (see the module docstring)."""
    settings = Settings().with_cameras(remotes)
    world = SimWorld(settings, seed=seed)
    world.connect()
    rng = np.random.default_rng(seed + 1)
    world.wave_wand(seconds, WAND_M, rng)
    observations = capture_wand(world.rig, world.clock, seconds)
    world.hold(None)
    start = time.perf_counter()
    wand = calibrate_wand(
        observations, WAND_M, focal_px=settings.rig.focal_px, center_px=settings.rig.center_px, rng=rng
    )
    fit_s = time.perf_counter() - start
    world.light("marker", True)
    robot = calibrate_with_robot(
        world.arm,
        world.arm_model,
        world.rig,
        world.clock,
        nominal_cameras(settings.rig),
        n_poses=poses,
        rng=np.random.default_rng(seed + 2),
        show_progress=False,
    )
    world.close()
    candidates = sample_candidates(world.arm_model, world.cameras, np.random.default_rng(seed + 3))
    test_rng = np.random.default_rng(seed + 4)
    truth = candidates.positions[test_rng.choice(len(candidates), min(TEST_POINTS, len(candidates)), replace=False)]
    sigma = settings.noise.pixel_sigma_px
    image = np.stack([c.observe(truth, test_rng, sigma_px=sigma, max_blobs=None) for c in world.cameras])
    true_Ps = world.true_calibration_Ps()
    errors = {
        name: aligned_error_m(Ps, image, truth)
        for name, Ps in (("wand", wand.calibration.Ps), ("robot", robot.calibration.Ps), ("true", true_Ps))
    }
    labels = wand.labels
    used = labels.usable & ~wand.heldout
    true_lengths, _ = wand_lengths(true_Ps, labels.pixels)
    true_lengths = true_lengths[used & np.isfinite(true_lengths)]
    q = wand.quality
    return {
        "wand_s": seconds,
        "robot_poses": len(robot.data),
        "ratio_to_robot": errors["wand"] / errors["robot"],
        "wand_test_error_mm": 1e3 * errors["wand"],
        "robot_test_error_mm": 1e3 * errors["robot"],
        "true_cameras_test_error_mm": 1e3 * errors["true"],
        "test_points": len(truth),
        "wand_score_percent": q.wand_score_percent,
        "true_cameras_wand_score_percent": 100 * float(np.std(true_lengths) / np.mean(true_lengths)),
        "reprojection_rms_px": list(q.reprojection_rms_px),
        "heldout_length_rms_mm": 1e3 * q.heldout_length_rms_m,
        "coverage": list(q.coverage_fraction),
        "frames": {"recorded": q.frames_total, "usable": q.frames_usable, "fitted": q.frames_fitted},
        "fit_s": fit_s,
        "bundle_s": wand.bundle.seconds,
        "warnings": list(q.warnings),
    }


def run(quick: bool = False) -> dict[str, Any]:
    seconds, poses = (10.0, 8) if quick else (60.0, 30)
    return {f"remotes_{n}": measure(n, seconds, poses) for n in (2, 4)}
