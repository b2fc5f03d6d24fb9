"""`point_in_common_view` decides as `in_common_view` does, point by point: far from the edges by its
own arithmetic, at the edges (within `EDGE_TOLERANCE`) by `in_common_view` itself."""

import numpy as np
import pytest

from wiithrow.vision.camera import WiimoteCamera
from wiithrow.vision.rig import EDGE_TOLERANCE, in_common_view, point_in_common_view, stereo_rig


def on_the_edge(camera: WiimoteCamera, u: float, v: float, depth: float) -> np.ndarray:
    """The point (frame) at `depth` on the ray of pixel (u, v) of a pinhole camera."""
    ray = np.linalg.solve(camera.K, [u, v, 1.0]) * depth
    return camera.R.T @ (ray - camera.t)


@pytest.mark.parametrize("count", [2, 3, 4])
@pytest.mark.parametrize("margin_px", [0.0, 20.0])
def test_the_same_decision_as_in_common_view_everywhere(count, margin_px):
    cameras = stereo_rig(count=count, converge_m=1.0 if count > 2 else 0.0)
    rng = np.random.default_rng(count)
    points = rng.uniform([-0.5, -1.5, -1.0], [2.5, 1.5, 1.5], (4000, 3))
    # and points on every edge of cam0's image (and a hair inside and outside it), at 0.3-2 m
    w, h = cameras[0].width - 1, cameras[0].height - 1
    edges = []
    for hair in (0.0, 1e-9, -1e-9, 2 * EDGE_TOLERANCE, -2 * EDGE_TOLERANCE):
        for depth in (0.3, 1.0, 2.0):
            for u, v in ((margin_px, h / 2), (w - margin_px, h / 2), (w / 2, margin_px), (w / 2, h - margin_px)):
                inward_u = hair if u == margin_px else -hair if u == w - margin_px else 0.0
                inward_v = hair if v == margin_px else -hair if v == h - margin_px else 0.0
                edges.append(on_the_edge(cameras[0], u + inward_u, v + inward_v, depth))
    points = np.vstack([points, edges, cameras[0].center])  # the last: at the camera, no image
    expected = in_common_view(cameras, points, margin_px)
    assert 100 < expected.sum() < len(points) - 100  # both answers are well represented
    assert [point_in_common_view(cameras, p, margin_px) for p in points] == expected.tolist()


def test_a_camera_with_skew_is_left_to_in_common_view():
    cam = stereo_rig(count=2)[0]
    skewed = WiimoteCamera(K=cam.K + np.array([[0.0, 5.0, 0.0], [0.0, 0.0, 0.0], [0.0, 0.0, 0.0]]), R=cam.R, t=cam.t)
    assert not skewed.pinhole and cam.pinhole
    points = np.random.default_rng(0).uniform([0.3, -1.0, -0.5], [2.0, 1.0, 1.0], (500, 3))
    expected = in_common_view([skewed, cam], points, 20.0)
    assert 0 < expected.sum() < len(points)
    assert [point_in_common_view([skewed, cam], p, 20.0) for p in points] == expected.tolist()
