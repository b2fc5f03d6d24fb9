"""Fig. 5: actual against calculated positions of the calibration set.

Actual: the marker's position from the forward kinematics of the measured joints (link1).
Calculated: the same poses' averaged pixels triangulated with the calibrated rig (eq. 11-13).
Per axis, the figure shows both over the pose index and the difference below.
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from wiithrow.app.studies.figures import new_figure, save_png, write_csv
from wiithrow.vision import StereoCalibration


@dataclass(frozen=True)
class ActualVsCalculated:
    actual: NDArray[np.float64]  # (N, 3) m, link1
    calculated: NDArray[np.float64]  # (N, 3) m, link1

    @property
    def error(self) -> NDArray[np.float64]:
        return self.calculated - self.actual

    @property
    def rms_m(self) -> NDArray[np.float64]:
        """RMS difference per axis (3,)."""
        return np.sqrt(np.nanmean(self.error**2, axis=0))

    @property
    def mean_abs_3d_m(self) -> float:
        return float(np.nanmean(np.linalg.norm(self.error, axis=1)))


def actual_vs_calculated(
    calibration: StereoCalibration, world: NDArray[np.float64], image: NDArray[np.float64]
) -> ActualVsCalculated:
    """Triangulate the calibration set's pixels (C, N, 2) with `calibration`; compare with `world` (N, 3)."""
    return ActualVsCalculated(np.asarray(world, dtype=float), calibration.triangulate(image).points)


def write_fig5(data: ActualVsCalculated, out_dir: str | os.PathLike[str]) -> list[Path]:
    """fig5_actual_vs_calculated.csv and .png."""
    out_dir = Path(out_dir)
    rows = [(i, *map(float, a), *map(float, c)) for i, (a, c) in enumerate(zip(data.actual, data.calculated))]
    csv_path = write_csv(
        out_dir / "fig5_actual_vs_calculated.csv",
        ["pose", "x_actual_m", "y_actual_m", "z_actual_m", "x_stereo_m", "y_stereo_m", "z_stereo_m"],
        rows,
    )
    fig = new_figure(9.0, 6.0)
    grid = fig.add_gridspec(2, 3, height_ratios=(3, 1))
    index = np.arange(len(data.actual))
    for k, axis in enumerate("xyz"):
        ax = fig.add_subplot(grid[0, k])
        ax.plot(index, data.actual[:, k], "-", color="black", lw=1.0, label="actual (FK)")
        ax.plot(index, data.calculated[:, k], "o", ms=3.5, mfc="none", color="tab:red", label="calculated (stereo)")
        ax.set_title(f"{axis} (link1)")
        ax.set_ylabel("m")
        ax.grid(True, alpha=0.3)
        if k == 0:
            ax.legend(fontsize=8)
        err = fig.add_subplot(grid[1, k], sharex=ax)
        err.plot(index, 1e3 * data.error[:, k], ".", color="tab:red")
        err.axhline(0, color="black", lw=0.6)
        err.set_xlabel("pose")
        err.set_ylabel("error (mm)")
        err.grid(True, alpha=0.3)
    fig.suptitle(
        f"Fig. 5: actual against calculated positions (RMS x, y, z: "
        f"{', '.join(f'{1e3 * v:.2f}' for v in data.rms_m)} mm)"
    )
    return [csv_path, save_png(fig, out_dir / "fig5_actual_vs_calculated.png")]
