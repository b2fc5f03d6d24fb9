"""`wiithrow bench triangulate`: points per second of `wiithrow.vision.triangulation`, against OpenCV.

100,000 points seen by 2 and by 4 simulated Wiimotes (sigma 0.5 px, integer pixels). When OpenCV
is installed (the optional `bench` extra), `cv2.triangulatePoints` runs on the same 2-view data in
the same process, once with our projection matrices as they are and once with each scaled to unit
norm (OpenCV's SVD runs about 4x faster then); `opencv_ratio` is our throughput over OpenCV's faster
run (goal >= 1.0).
"""

from __future__ import annotations

from functools import partial

import numpy as np
from numpy.typing import NDArray

from wiithrow.app.cli.bench.timing import best_of
from wiithrow.vision import triangulate
from wiithrow.vision.rig import observe_all, points_in_common_view, stereo_rig


def run(quick: bool = False) -> dict:
    n = 10_000 if quick else 100_000
    repeats = 3 if quick else 7
    rng = np.random.default_rng(0)
    result: dict[str, object] = {"points": n}
    two_view: tuple[NDArray[np.float64], NDArray[np.float64], float] | None = None
    for count in (2, 4):
        cameras = stereo_rig(count=count, baseline=0.25 if count == 2 else 0.15)
        X = points_in_common_view(cameras, n, rng)
        image = observe_all(cameras, X, rng)
        Ps = np.stack([c.P for c in cameras])
        seconds = best_of(partial(triangulate, Ps, image), repeats)
        refined = best_of(partial(triangulate, Ps, image, refine=True), max(1, repeats // 2))
        error = np.linalg.norm(triangulate(Ps, image).points - X, axis=1)
        result[f"cameras_{count}"] = {
            "points_per_s": n / seconds,
            "refined_points_per_s": n / refined,
            "mean_error_mm": 1e3 * float(np.nanmean(error)),
        }
        if count == 2:
            two_view = (Ps, image, seconds)
    try:
        import cv2
    except ImportError:
        result["opencv_ratio"] = None
        result["opencv_note"] = "OpenCV not installed: pip install -e '.[bench]' to compare"
        return result
    assert two_view is not None
    Ps, image, ours = two_view
    a, b = np.ascontiguousarray(image[0].T), np.ascontiguousarray(image[1].T)
    # OpenCV's SVD converges much faster when each P has unit Frobenius norm (ours are pixel-scaled,
    # ||P|| ~ 1e3): time both and compare with its faster run, so that the ratio is not flattered.
    unit = [P / np.linalg.norm(P) for P in Ps[:2]]
    as_given = best_of(lambda: cv2.triangulatePoints(Ps[0], Ps[1], a, b), repeats)
    unit_norm = best_of(lambda: cv2.triangulatePoints(unit[0], unit[1], a, b), repeats)
    result["opencv_points_per_s"] = n / as_given
    result["opencv_unit_norm_points_per_s"] = n / unit_norm
    result["opencv_ratio"] = min(as_given, unit_norm) / ours
    result["opencv_version"] = cv2.__version__
    return result
