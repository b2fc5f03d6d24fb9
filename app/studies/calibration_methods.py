"""The simulated calibration study behind `wiithrow calibrate --demo` and the paper's Fig. 4.

A Wiimote stereo rig as in the paper (two cameras 0.25 m apart, f = 1300 px), calibration points in
the common field of view at 0.5-1.2 m, pixels with sigma = 0.5 px noise rounded to integers. Every
calibration method is compared with the true cameras on test points in the same volume: the true
cameras' error on the same noisy pixels is the irreducible part, so the ratio says what the
calibration itself costs.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from wiithrow.vision import calibrate, leave_one_out, triangulate
from wiithrow.vision.dlt import METHODS, Method
from wiithrow.vision.rig import observe_all, points_in_common_view, stereo_rig


@dataclass(frozen=True)
class MethodResult:
    method: str
    rms_px: float  # mean over cameras of the calibration RMS
    loo_mm: float  # leave-one-out mean 3D error
    test_mm: float  # mean 3D error on the test points
    ratio: float  # test error / true cameras' test error
    focal_error_pct: float  # worst camera
    center_error_mm: float  # worst camera


@dataclass(frozen=True)
class DemoResult:
    n_points: int
    n_test: int
    sigma_px: float
    true_test_mm: float
    methods: list[MethodResult]
    #: Depth (m) of the frame's origin in each camera: near 0, the paper's a34 = 1 is ill-posed.
    origin_depth_m: list[float]


def run_demo(
    rng: np.random.Generator,
    *,
    n_points: int = 30,
    n_test: int = 2000,
    sigma_px: float = 0.5,
    depth_m: tuple[float, float] = (0.5, 1.2),
    methods: tuple[Method, ...] = METHODS,
    cross_validate: bool = True,
) -> DemoResult:
    """Calibrate a simulated rig with every method and measure each against the true cameras."""
    cameras = stereo_rig()  # the default world's rig: on link1, 0.35 m up, pitched down 5 degrees
    world = points_in_common_view(cameras, n_points, rng, depth_m=depth_m)
    image = observe_all(cameras, world, rng, sigma_px=sigma_px)
    test = points_in_common_view(cameras, n_test, rng, depth_m=depth_m)
    test_image = observe_all(cameras, test, rng, sigma_px=sigma_px)
    true_Ps = np.stack([c.P for c in cameras])
    true_mm = 1e3 * float(np.nanmean(np.linalg.norm(triangulate(true_Ps, test_image).points - test, axis=1)))
    results = []
    for method in methods:
        fits = [calibrate(world, image[c], method, name=f"cam{c}") for c in range(len(cameras))]
        Ps = np.stack([f.P for f in fits])
        test_mm = 1e3 * float(np.nanmean(np.linalg.norm(triangulate(Ps, test_image).points - test, axis=1)))
        focal = max(abs(f.decompose().K[0, 0] / c.K[0, 0] - 1) for f, c in zip(fits, cameras))
        center = max(np.linalg.norm(f.decompose().center - c.center) for f, c in zip(fits, cameras))
        loo = leave_one_out(world, image, method).mean if cross_validate else float("nan")
        results.append(
            MethodResult(
                method,
                float(np.mean([f.rms_px for f in fits])),
                1e3 * loo,
                test_mm,
                test_mm / true_mm,
                100 * focal,
                1e3 * float(center),
            )
        )
    return DemoResult(n_points, n_test, sigma_px, true_mm, results, [float(c.t[2]) for c in cameras])
