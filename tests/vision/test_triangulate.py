"""N-view triangulation: exactness, NaN handling, weighting, refinement, real data."""

import numpy as np
import pytest

from tests.helpers.vgg_house import load_house
from wiithrow.vision import TriangulationError, triangulate
from wiithrow.vision.rig import observe_all, points_in_common_view, stereo_rig


def rig(count=2):
    return stereo_rig(count=count, baseline=0.25)


def reference_loop(Ps, image):
    """Independent per-point implementation: stacked rows, numpy lstsq (eq. 11-13)."""
    out = []
    for n in range(image.shape[1]):
        rows, rhs = [], []
        for P, (u, v) in zip(Ps, image[:, n]):
            if np.isnan(u):
                continue
            P = P / np.linalg.norm(P[2, :3])
            for r in (u * P[2] - P[0], v * P[2] - P[1]):
                rows.append(r[:3])
                rhs.append(-r[3])
        if len(rows) < 4:
            out.append([np.nan] * 3)
        else:
            out.append(np.linalg.lstsq(np.array(rows), np.array(rhs), rcond=None)[0])
    return np.array(out)


def test_exact_pixels_give_exact_points_for_any_camera_count():
    rng = np.random.default_rng(0)
    for count in (2, 3, 4):
        cams = rig(count)
        X = points_in_common_view(cams, 200, rng)
        image = np.stack([c.project(X) for c in cams])
        result = triangulate(np.stack([c.P for c in cams]), image)
        assert np.max(np.abs(result.points - X)) < 1e-9
        assert np.max(result.reprojection_error_px) < 1e-6
        assert np.all(result.n_views == count)


def test_vectorised_solve_equals_the_per_point_least_squares():
    rng = np.random.default_rng(1)
    cams = rig(3)
    X = points_in_common_view(cams, 300, rng)
    image = observe_all(cams, X, rng)
    image[0, ::7] = np.nan
    image[2, ::5] = np.nan
    Ps = np.stack([c.P for c in cams]) * np.array([3.0, -0.5, 100.0])[:, None, None]  # any scale, any sign
    ours = triangulate(Ps, image).points
    assert np.allclose(ours, reference_loop(Ps, image), atol=1e-9, equal_nan=True)


def test_points_seen_by_fewer_than_two_cameras_are_nan():
    rng = np.random.default_rng(2)
    cams = rig(3)
    X = points_in_common_view(cams, 6, rng)
    image = np.stack([c.project(X) for c in cams])
    image[:, 0] = np.nan  # nobody
    image[1:, 1] = np.nan  # only camera 0
    image[0, 2] = np.nan  # cameras 1 and 2
    result = triangulate(np.stack([c.P for c in cams]), image)
    assert np.isnan(result.points[:2]).all()
    assert list(result.n_views[:3]) == [0, 1, 2]
    assert np.allclose(result.points[2:], X[2:], atol=1e-9)


def test_refinement_lowers_reprojection_error_and_never_raises_it():
    rng = np.random.default_rng(3)
    cams = stereo_rig(count=3, baseline=0.4)
    X = points_in_common_view(cams, 2000, rng, depth_m=(0.5, 2.5))
    image = observe_all(cams, X, rng, sigma_px=1.0)
    Ps = np.stack([c.P for c in cams])
    linear = triangulate(Ps, image)
    refined = triangulate(Ps, image, refine=True)
    assert np.all(refined.reprojection_error_px <= linear.reprojection_error_px + 1e-9)
    assert refined.reprojection_error_px.mean() < linear.reprojection_error_px.mean()


def test_bad_shapes_are_refused():
    P = np.stack([c.P for c in rig(2)])
    with pytest.raises(TriangulationError, match="at least 2 cameras"):
        triangulate(P[:1], np.zeros((1, 3, 2)))
    with pytest.raises(TriangulationError, match=r"\(C, N, 2\)"):
        triangulate(P, np.zeros((3, 4, 2)))
    with pytest.raises(TriangulationError, match="NaN or inf"):
        triangulate(np.where(P[0, 0, 0] == P, np.nan, P), np.zeros((2, 4, 2)))


def test_real_data_vgg_house_all_points_all_views():
    """672 points over all views that see them with the given P: mean 3D error <= 1e-3 units."""
    house = load_house()
    result = triangulate(house.Ps, house.image)
    error = np.linalg.norm(result.points - house.points, axis=1)
    assert np.isfinite(error).all()
    assert error.mean() <= 1e-3
    refined = triangulate(house.Ps, house.image, refine=True)
    assert np.linalg.norm(refined.points - house.points, axis=1).mean() <= error.mean()


def test_depth_normalisation_matters_on_real_data():
    """docs/calibration.md, "Calibration and triangulation pitfalls": scaling P so a34 = 1 before
    stacking rows is much worse than ||P[2,:3]|| = 1. Our triangulate must be scale-invariant: the
    a34 = 1 scaling gives the same answer."""
    house = load_house()
    scaled = house.Ps / house.Ps[:, 2:3, 3:4]
    a = triangulate(house.Ps, house.image).points
    b = triangulate(scaled, house.image).points
    assert np.allclose(a, b, atol=1e-9)
