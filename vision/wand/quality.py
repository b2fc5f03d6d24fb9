"""How good a wand calibration is, in figures a user can read.

* Reprojection RMS per camera (px): sqrt(mean ||x - pi(X)||^2) over the fitted observations (the
  Wiimote's noise, 0.5 px before rounding to integers, gives about 0.5 px).
* The wand length over every usable frame, each end triangulated on its own (N-view, with
  Gauss-Newton refinement) by the calibrated cameras: its mean, its standard deviation, and their
  ratio in percent, easyWand's "wand score" (Theriault et al. 2014): 100 std(l) / mean(l). The fit
  holds the length at L, so a mean away from L or a large score says the cameras disagree.
* The held-out error: frames in one-second blocks left out of the fit (consecutive frames at
  100 Hz are near repeats, so single frames would not be new data), triangulated like the rest;
  the wand length is known, so each held-out frame gives a 3D error without ground truth, l_k - L
  (m): its RMS, and the held-out frames' reprojection RMS. Frames whose length is a gross outlier
  (`ends.OUTLIER_MADS`: a wrong dot, not the calibration) are left out of both and counted.
* Coverage: per camera, how many wand dots fell in each cell of a grid over the 1024 x 768 image
  (128 px cells: 8 x 6); the fraction of cells visited at least `MIN_DOTS_PER_CELL` times. Where
  the wand never went the calibration extrapolates (lens centre and focal length are fitted from
  where the dots were), so a fraction under `MIN_COVERAGE` gives a warning naming the camera.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, replace
from typing import Any

import numpy as np
from numpy.typing import NDArray

from wiithrow.vision.triangulation import triangulate

#: Coverage grid cell (px): 8 x 6 cells over the 1024 x 768 image.
CELL_PX = 128
#: A cell counts as visited with at least this many dots.
MIN_DOTS_PER_CELL = 3
#: Below this visited fraction of a camera's image the result warns.
MIN_COVERAGE = 0.5
#: Above this wand score (percent) the result warns.
MAX_WAND_SCORE_PERCENT = 1.0


@dataclass(frozen=True)
class WandQuality:
    """The figures of the module docstring; `coverage` (C, rows, cols) counts dots per cell."""

    names: tuple[str, ...]
    reprojection_rms_px: tuple[float, ...]
    observations: tuple[int, ...]
    length_mean_m: float
    length_std_m: float
    frames_total: int
    frames_usable: int
    frames_fitted: int
    length_outliers: int
    heldout_frames: int
    heldout_length_rms_m: float
    heldout_reprojection_px: float
    coverage: NDArray[np.int64]
    warnings: tuple[str, ...]

    @property
    def wand_score_percent(self) -> float:
        """easyWand's wand score: 100 std(l) / mean(l)."""
        return 100.0 * self.length_std_m / self.length_mean_m

    @property
    def coverage_fraction(self) -> tuple[float, ...]:
        visited = (self.coverage >= MIN_DOTS_PER_CELL).reshape(len(self.names), -1)
        return tuple(float(v) for v in visited.mean(axis=1))

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready figures (the coverage maps as lists of rows)."""
        return {
            "cameras": [
                {"name": n, "reprojection_rms_px": r, "observations": o, "coverage": f, "coverage_map": m.tolist()}
                for n, r, o, f, m in zip(
                    self.names, self.reprojection_rms_px, self.observations, self.coverage_fraction, self.coverage
                )
            ],
            "wand_length_mean_m": self.length_mean_m,
            "wand_length_std_m": self.length_std_m,
            "wand_score_percent": self.wand_score_percent,
            "frames": {
                "total": self.frames_total,
                "usable": self.frames_usable,
                "fitted": self.frames_fitted,
                "length_outliers": self.length_outliers,
                "held_out": self.heldout_frames,
            },
            "heldout_length_rms_m": self.heldout_length_rms_m,
            "heldout_reprojection_px": self.heldout_reprojection_px,
            "warnings": list(self.warnings),
        }


def coverage_map(pixels: NDArray[np.float64], image_size: tuple[int, int]) -> NDArray[np.int64]:
    """Dots per grid cell (rows, cols) of one camera's dots (..., 2), NaN ignored."""
    width, height = image_size
    cols, rows = -(-width // CELL_PX), -(-height // CELL_PX)
    uv = pixels.reshape(-1, 2)
    uv = uv[np.isfinite(uv).all(axis=1)]
    c = np.clip((uv[:, 0] // CELL_PX).astype(np.int64), 0, cols - 1)
    r = np.clip((uv[:, 1] // CELL_PX).astype(np.int64), 0, rows - 1)
    counts = np.zeros((rows, cols), dtype=np.int64)
    np.add.at(counts, (r, c), 1)
    return counts


def wand_lengths(
    Ps: NDArray[np.float64], pixels: NDArray[np.float64]
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Each frame's triangulated wand length (N,) and RMS reprojection error (N,) from labelled
    pixels (C, N, 2, 2) (end 0 of every camera one LED); NaN where an end has fewer than 2 views."""
    C, N = pixels.shape[:2]
    result = triangulate(Ps, pixels.transpose(0, 2, 1, 3).reshape(C, 2 * N, 2), refine=True)
    X = result.points
    error = np.sqrt((result.reprojection_error_px[:N] ** 2 + result.reprojection_error_px[N:] ** 2) / 2)
    return np.linalg.norm(X[:N] - X[N:], axis=1), error


def assess(
    Ps: NDArray[np.float64],
    labelled: NDArray[np.float64],
    usable: NDArray[np.bool_],
    heldout: NDArray[np.bool_],
    residuals_px: NDArray[np.float64],
    obs_camera: NDArray[np.int64],
    frames_fitted: int,
    length_outliers: int,
    wand_length_m: float,
    names: Sequence[str],
    image_size: tuple[int, int],
) -> WandQuality:
    """The quality of cameras Ps (C, 3, 4) on labelled observations (C, N, 2, 2): `usable` (N,)
    frames had their ends ordered, `heldout` (N,) were left out of the fit; the fit's residuals
    (n, 2) with each one's camera (n,)."""
    C = len(names)
    rms = tuple(float(np.sqrt(np.mean(np.sum(residuals_px[obs_camera == c] ** 2, axis=1)))) for c in range(C))
    counts = tuple(int((obs_camera == c).sum()) for c in range(C))
    lengths, reprojection = wand_lengths(Ps, labelled)
    fitted_lengths = lengths[usable & ~heldout & np.isfinite(lengths)]
    held = usable & heldout & np.isfinite(lengths)
    coverage = np.stack([coverage_map(labelled[c], image_size) for c in range(C)])
    quality = WandQuality(
        tuple(names),
        rms,
        counts,
        float(np.mean(fitted_lengths)),
        float(np.std(fitted_lengths)),
        int(labelled.shape[1]),
        int(usable.sum()),
        frames_fitted,
        length_outliers,
        int(held.sum()),
        float(np.sqrt(np.mean((lengths[held] - wand_length_m) ** 2))) if held.any() else float("nan"),
        float(np.sqrt(np.mean(reprojection[held] ** 2))) if held.any() else float("nan"),
        coverage,
        (),
    )
    warnings = [
        f"{name}: the wand visited {100 * f:.0f} % of the image (under {100 * MIN_COVERAGE:.0f} %); wave it "
        "into the image's corners and edges too"
        for name, f in zip(names, quality.coverage_fraction)
        if f < MIN_COVERAGE
    ]
    if quality.wand_score_percent > MAX_WAND_SCORE_PERCENT:
        warnings.append(
            f"the wand's length varies by {quality.wand_score_percent:.2f} % between frames (over "
            f"{MAX_WAND_SCORE_PERCENT:g} %): the remotes are close together for the distance (the depth error grows "
            "as distance^2 / baseline), a remote moved during the recording, or another IR source was in view"
        )
    return replace(quality, warnings=tuple(warnings))
