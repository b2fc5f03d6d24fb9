"""What a wand calibration tells its user: coverage maps and the warnings they give."""

import numpy as np

from tests.helpers.wand_rigs import wide_pair
from wiithrow.vision.wand.calibrate import calibrate_wand
from wiithrow.vision.wand.quality import MIN_COVERAGE, coverage_map
from wiithrow.vision.wand.waver import wave_wand


def test_coverage_counts_dots_in_128_px_cells():
    dots = np.array([[[0, 0], [127, 127]], [[128, 0], [np.nan, np.nan]], [[1023, 767], [600, 300]]], dtype=float)
    counts = coverage_map(dots, (1024, 768))
    assert counts.shape == (6, 8) and counts.sum() == 5
    assert counts[0, 0] == 2 and counts[0, 1] == 1 and counts[5, 7] == 1 and counts[2, 4] == 1


def test_a_wand_kept_in_one_half_of_an_image_is_reported():
    rig = wide_pair()
    observations, _ = wave_wand(rig.cameras, 30, np.random.default_rng(50), depth_m=rig.depth_m)
    u = observations.pixels[0, :, :, 0]
    left = np.all(np.isnan(u) | (u < 512), axis=1)  # cam0 saw the wand in its left half, or not at all
    result = calibrate_wand(observations.subset(left), 0.3)
    fraction = result.quality.coverage_fraction
    assert fraction[0] <= 0.5  # of 0.92 for the whole recording
    warned = {w.split(":")[0] for w in result.quality.warnings if "the wand visited" in w}
    assert "cam0" in warned and warned == {f"cam{c}" for c, f in enumerate(fraction) if f < MIN_COVERAGE}
