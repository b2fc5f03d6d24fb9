"""The Wand panel's pictures and text, without a browser."""

import numpy as np

from wiithrow.app.calibration.wand_capture import CaptureProgress
from wiithrow.web.wand_panel import coverage_image, wand_summary


def test_coverage_image_shows_visited_cells_brighter_than_empty_ones():
    counts = np.zeros((6, 8), dtype=np.int64)
    counts[0, 0], counts[5, 7], counts[2, 3] = 200, 3, 1
    image = coverage_image(counts, width=256, height=192)
    assert image.shape == (192, 256, 3) and image.dtype == np.uint8
    cell = lambda r, c: image[32 * r + 16, 32 * c + 16]  # noqa: E731
    assert cell(0, 0)[1] > cell(5, 7)[1] > cell(1, 1)[1]  # many dots brighter than a few, a few than none
    assert tuple(cell(2, 3)) != tuple(cell(1, 1)) and cell(2, 3)[1] < cell(5, 7)[1]  # one dot: not yet visited


def test_summary_says_what_is_happening():
    assert "press **Start**" in wand_summary(None, None, False)
    progress = CaptureProgress(0.25, 1500, np.array([1400, 1390]), np.zeros((2, 6, 8), dtype=np.int64))
    text = wand_summary(None, progress, True)
    assert "25 %" in text and "1400, 1390" in text
