"""Correspondence of up to four dots per camera: epipolar matching, predictions, ghosts."""

import numpy as np
import pytest

from wiithrow.vision import TriangulationError
from wiithrow.vision.correspondence import Correspondence, epipolar_cost, fundamental_matrix, gated_assignment
from wiithrow.vision.rig import points_in_common_view, stereo_rig


def shuffled_dots(cams, X, rng, sigma=0.5):
    """Each camera reports the points in its own random slot order (the remotes do not agree)."""
    dots, orders = [], []
    for cam in cams:
        order = rng.permutation(len(X))
        dots.append(cam.observe(X[order], rng, sigma_px=sigma))
        orders.append(order)
    return np.stack(dots), orders


def test_fundamental_matrix_satisfies_the_epipolar_constraint():
    a, b = stereo_rig()
    X = points_in_common_view([a, b], 50, np.random.default_rng(0))
    F = fundamental_matrix(a.P, b.P)
    cost = epipolar_cost(F, a.project(X), b.project(X))
    assert np.max(np.diag(cost)) < 1e-6


def test_gated_assignment_leaves_rows_alone_rather_than_forcing_bad_pairs():
    cost = np.array([[1.0, 50.0], [2.0, 60.0]])
    assert gated_assignment(cost, 4.0) == [(0, 0)]
    # a full assignment would be cheaper overall by pairing (0,1),(1,0) if the gate allowed it
    assert sorted(gated_assignment(np.array([[3.0, 1.0], [1.0, 9.0]]), 10.0)) == [(0, 1), (1, 0)]
    assert gated_assignment(np.zeros((0, 3)), 1.0) == []


@pytest.mark.parametrize("count", [2, 3, 4])
def test_four_markers_matched_without_predictions(count):
    cams = stereo_rig(count=count, baseline=0.25 if count == 2 else 0.2)
    rng = np.random.default_rng(count)
    correct = 0
    for _ in range(50):
        X = points_in_common_view(cams, 4, rng)
        dots, orders = shuffled_dots(cams, X, rng)
        markers = Correspondence(np.stack([c.P for c in cams])).match(dots)
        for point, slots in zip(markers.points, markers.slots):
            truth = {orders[c][k] for c, k in enumerate(slots) if k >= 0}
            correct += len(truth) == 1 and np.linalg.norm(point - X[truth.pop()]) < 0.02
    # two cameras cannot tell apart markers that share an epipolar plane; more cameras can
    assert correct >= (0.93 if count == 2 else 0.99) * 200


def test_a_dot_seen_by_one_camera_only_is_not_forced_into_a_match():
    cams = stereo_rig()
    rng = np.random.default_rng(1)
    X = points_in_common_view(cams, 3, rng)
    dots = np.stack([c.observe(np.vstack([X, [[10.0, 0.0, 0.0]]]), rng) for c in cams])  # 4 slots
    dots[1, 2] = np.nan  # camera 1 misses marker 2
    dots[0, 3] = [100.0, 700.0]  # and camera 0 sees a reflection nobody else sees
    markers = Correspondence(np.stack([c.P for c in cams])).match(dots)
    assert len(markers.points) == 2
    assert markers.unmatched[0, 2] and markers.unmatched[0, 3]
    assert np.all(markers.reprojection_px < 4.0)


def test_predictions_resolve_the_epipolar_ghost():
    """Two markers in one epipolar plane pair either way from geometry alone; predictions decide."""
    cams = stereo_rig()
    # both markers on the plane through both optical centres (y-axis baseline) and a point
    X = np.array([[0.8, 0.05, 0.30], [1.2, -0.10, 0.30]])
    centres = np.array([c.center for c in cams])
    normal = np.cross(centres[1] - centres[0], X[0] - centres[0])
    X[1] -= normal * ((X[1] - centres[0]) @ normal) / (normal @ normal)  # project onto that plane
    rng = np.random.default_rng(0)
    dots = np.stack([c.observe(X[::-1] if i else X, rng, sigma_px=0.0) for i, c in enumerate(cams)])
    corr = Correspondence(np.stack([c.P for c in cams]))
    guided = corr.match(dots, predicted=X + 0.003)  # a prediction 3 mm off
    assert len(guided.points) == 2
    assert np.allclose(np.sort(guided.points[:, 0]), np.sort(X[:, 0]), atol=0.005)
    assert list(guided.predicted_index) == [0, 1]


def test_bad_shapes():
    cams = stereo_rig()
    with pytest.raises(TriangulationError):
        Correspondence(np.stack([cams[0].P]))
    corr = Correspondence(np.stack([c.P for c in cams]))
    with pytest.raises(TriangulationError, match="dots must have shape"):
        corr.match(np.zeros((3, 4, 2)))
