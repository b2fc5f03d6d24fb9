"""The simulated Wiimote rig study (`wiithrow calibrate --demo`): what calibration costs in 3D."""

import numpy as np

from wiithrow.app.studies.calibration_methods import run_demo


def test_refined_calibration_costs_at_most_15_percent_over_the_true_cameras():
    """30 points, sigma 0.5 px, integer pixels: the mean 3D error on 2,000 test points with the
    calibrated cameras is <= 1.15x the error of the true cameras on the same noisy pixels.
    Averaged over 8 seeded rigs (a single draw of 30 points varies by about +-7%)."""
    ratios = {m: [] for m in ("paper", "normalized", "refined", "robust")}
    for seed in range(8):
        result = run_demo(np.random.default_rng(seed), cross_validate=False)
        for m in result.methods:
            ratios[m.method].append(m.ratio)
            assert m.ratio >= 0.97  # nobody beats the true cameras by more than chance
    mean = {m: float(np.mean(r)) for m, r in ratios.items()}
    assert mean["refined"] <= 1.15, mean
    assert mean["robust"] <= 1.15, mean
    assert mean["refined"] <= mean["normalized"] + 0.01
    assert mean["refined"] < mean["paper"]


def test_demo_reports_every_method_with_sane_figures():
    result = run_demo(np.random.default_rng(0), n_test=300)
    assert [m.method for m in result.methods] == ["paper", "normalized", "refined", "robust"]
    refined = result.methods[2]
    assert 0.4 < refined.rms_px < 1.0
    assert 0.5 < refined.loo_mm < 6.0
    assert refined.focal_error_pct < 2.0 and refined.center_error_mm < 20.0
