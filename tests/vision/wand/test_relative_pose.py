"""The two-view geometry under the wand's first estimate: eight-point, essential matrix, cheirality."""

import numpy as np
import pytest

from wiithrow.vision.camera import WiimoteCamera
from wiithrow.vision.errors import DegenerateMotionError
from wiithrow.vision.wand.relative_pose import (
    closest_essential,
    eight_point,
    essential_poses,
    normalised,
    relative_pose,
    sampson_px,
)


def pair():
    """Two cameras 0.5 m apart, converging on a volume 1.5 m ahead, and the motion between them."""
    a = WiimoteCamera.at((0.0, 0.25, 1.0), (1.5, -0.25, -0.1))
    b = WiimoteCamera.at((0.0, -0.25, 1.1), (1.5, 0.25, -0.2))
    R = b.R @ a.R.T
    t = b.t - R @ a.t
    return a, b, R, t / np.linalg.norm(t)


def views(n, sigma_px, rng):
    a, b, R, t = pair()
    X = np.column_stack([rng.uniform(1.0, 2.0, n), rng.uniform(-0.4, 0.4, n), rng.uniform(0.6, 1.4, n)])
    xa = normalised(a.project(X) + rng.normal(0, sigma_px, (n, 2)), a.K)
    xb = normalised(b.project(X) + rng.normal(0, sigma_px, (n, 2)), b.K)
    return xa, xb, R, t


def angle_deg(R1, R2):
    return np.degrees(np.arccos(np.clip((np.trace(R1 @ R2.T) - 1) / 2, -1, 1)))


def test_eight_point_fits_exact_correspondences():
    xa, xb, _, _ = views(40, 0.0, np.random.default_rng(0))
    F = eight_point(xa, xb)
    assert np.linalg.matrix_rank(F, tol=1e-9) == 2
    assert sampson_px(F, xa, xb, 1300.0).max() < 1e-6


def test_the_motion_comes_back_through_the_essential_matrix_and_cheirality():
    xa, xb, R, t = views(200, 0.5, np.random.default_rng(1))
    R_est, t_est = relative_pose(closest_essential(eight_point(xa, xb)), xa, xb)
    assert angle_deg(R_est, R) < 0.2
    assert np.degrees(np.arccos(t_est @ t)) < 1.0


def test_only_one_of_the_four_motions_puts_the_points_in_front():
    xa, xb, R, t = views(50, 0.0, np.random.default_rng(2))
    E = closest_essential(eight_point(xa, xb))
    candidates = essential_poses(E)
    assert len(candidates) == 4
    close = [angle_deg(Ri, R) < 1e-3 and ti @ t > 0.999 for Ri, ti in candidates]
    assert sum(close) == 1


def test_a_batch_of_samples_is_fitted_at_once():
    rng = np.random.default_rng(3)
    xa, xb, _, _ = views(80, 0.0, rng)
    F = eight_point(xa.reshape(10, 8, 2), xb.reshape(10, 8, 2))
    assert F.shape == (10, 3, 3)
    assert all(sampson_px(F[i], xa[8 * i : 8 * i + 8], xb[8 * i : 8 * i + 8], 1300.0).max() < 1e-6 for i in range(10))


def test_points_that_are_not_one_scene_are_refused():
    rng = np.random.default_rng(4)
    xa, xb, _, _ = views(60, 0.0, rng)
    with pytest.raises(DegenerateMotionError, match="in front of both cameras"):
        shuffled = xb[rng.permutation(len(xb))]
        relative_pose(closest_essential(eight_point(xa, shuffled)), xa, shuffled)
