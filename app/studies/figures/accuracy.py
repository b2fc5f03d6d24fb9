"""Fig. 4: mean leave-one-out 3D error against the number of calibration points, per method.

The data are gathered once (the robot-driven calibration's N poses: marker positions by forward
kinematics and averaged pixels); each point of the curve is the mean, over `draws` seeded random
subsets of n of those poses, of the leave-one-out mean 3D error

    LOO(n) = mean_i || triangulate({P_c^(-i)}, x_i) - X_i ||      (vision.leave_one_out)

for the methods `paper`, `normalized`, `refined` and `robust`. With n = N every draw is the same
set, so it is computed once. Leave-one-out needs 6 points left after removing one, so the curve
starts at n = 7 (6 points calibrate a camera but cannot cross-validate it).

The paper's claim: the error is minimal from about 30 points. `knee` measures it: the smallest n
from which the refined curve stays within 10 % of its value at N. The relative curve is paired:
for a subset S, the mean LOO error of S's points over the mean LOO error of the SAME points in the
N-point calibration,

    rel(n) = mean over draws of  sum_{i in S} e_i^(S) / sum_{i in S} e_i^(N),

which removes the subsets' composition (near points err less than far ones) from the comparison:
its spread over draws is about a third of the plain ratio's.
"""

from __future__ import annotations

import os
import warnings
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from wiithrow.app.progress import progress_bar
from wiithrow.app.studies.figures import new_figure, save_png, write_csv
from wiithrow.vision import leave_one_out
from wiithrow.vision.dlt import METHODS, Method

FULL_SIZES = (7, 8, 10, 12, 15, 20, 25, 30, 40, 50, 60)
QUICK_SIZES = (7, 10, 15, 20, 30)


@dataclass(frozen=True)
class LooCurve:
    """`loo_m[method]` (S, D): LOO mean error (m) for each size of `sizes` and draw (NaN where a
    draw could not be cross-validated, and for the draws after the first at n = N); `paired[method]`
    (S, D): the same subsets' error over their points' error in the N-point set (docstring)."""

    sizes: tuple[int, ...]
    methods: tuple[str, ...]
    loo_m: dict[str, NDArray[np.float64]]
    paired: dict[str, NDArray[np.float64]]

    def mean(self, method: str) -> NDArray[np.float64]:
        """Mean over draws (S,); NaN for a size no draw could cross-validate (said in the docstring
        above, so numpy's "Mean of empty slice" warning is not repeated on the terminal)."""
        with np.errstate(invalid="ignore"), warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)
            return np.nanmean(self.loo_m[method], axis=1)

    def relative(self, method: str) -> NDArray[np.float64]:
        """Paired error relative to the largest size (S,), mean over draws (module docstring)."""
        with np.errstate(invalid="ignore"):
            return np.nanmean(self.paired[method], axis=1)

    def knee(self, method: str = "refined", within: float = 0.10) -> int:
        """Smallest n from which the mean stays within `within` of its value at the largest n."""
        rel = self.relative(method)
        ok = rel <= 1.0 + within
        for k in range(len(self.sizes)):
            if ok[k:].all():
                return self.sizes[k]
        return self.sizes[-1]


def loo_curve(
    world: NDArray[np.float64],
    image: NDArray[np.float64],
    rng: np.random.Generator,
    *,
    sizes: tuple[int, ...] = FULL_SIZES,
    draws: int = 5,
    methods: tuple[Method, ...] = tuple(METHODS),
    show_progress: bool = True,
) -> LooCurve:
    """Fig. 4's data from N measured poses: world (N, 3), image (C, N, 2)."""
    N = world.shape[0]
    sizes = tuple(n for n in sizes if n <= N)
    if not sizes or sizes[-1] != N:
        sizes = sizes + (N,)
    out: dict[str, NDArray[np.float64]] = {m: np.full((len(sizes), draws), np.nan) for m in methods}
    paired: dict[str, NDArray[np.float64]] = {m: np.full((len(sizes), draws), np.nan) for m in methods}
    # the full set first (every subset is compared with it), then the subsets
    jobs = [(len(sizes) - 1, 0)] + [(s, d) for s in range(len(sizes) - 1) for d in range(draws)]
    subsets = {
        (s, d): np.sort(rng.choice(N, sizes[s], replace=False)) if sizes[s] < N else np.arange(N) for s, d in jobs
    }
    full: dict[str, NDArray[np.float64]] = {}
    with progress_bar(
        total=len(jobs) * len(methods), show=show_progress, desc="Fig. 4 leave-one-out", unit="fit", leave=False
    ) as bar:
        for s, d in jobs:
            idx = subsets[(s, d)]
            for method in methods:
                errors = leave_one_out(world[idx], image[:, idx], method).errors
                full.setdefault(method, errors)
                ok = np.isfinite(errors) & np.isfinite(full[method][idx])
                with np.errstate(invalid="ignore"):
                    out[method][s, d] = np.nanmean(errors) if np.isfinite(errors).any() else np.nan
                    paired[method][s, d] = errors[ok].sum() / full[method][idx][ok].sum() if ok.any() else np.nan
                bar.update(1)
    return LooCurve(sizes, tuple(methods), out, paired)


def write_fig4(curve: LooCurve, out_dir: str | os.PathLike[str]) -> list[Path]:
    """fig4_loo_vs_points.csv (every draw) and .png (means, with the knee of the refined curve)."""
    out_dir = Path(out_dir)
    rows = []
    for method in curve.methods:
        for s, n in enumerate(curve.sizes):
            for d, value in enumerate(curve.loo_m[method][s]):
                if np.isfinite(value) or d == 0:
                    rows.append((method, n, d, float(1e3 * value), float(curve.paired[method][s, d])))
    csv_path = write_csv(
        out_dir / "fig4_loo_vs_points.csv",
        ["method", "n_points", "draw", "loo_error_mm", "relative_to_all_points_paired"],
        rows,
    )
    fig = new_figure()
    ax = fig.add_subplot()
    for method, style in zip(curve.methods, ("s--", "o-", "^-", "x:")):
        ax.plot(curve.sizes, 1e3 * curve.mean(method), style, label=method)
    ref = 1e3 * curve.mean("refined")[-1] if "refined" in curve.methods else None
    if ref is not None:
        ax.axhline(1.1 * ref, color="grey", lw=0.8, ls=":", label=f"refined at {curve.sizes[-1]} points + 10 %")
        ax.axvline(curve.knee("refined"), color="grey", lw=0.8, ls="--", label="knee (paired, refined)")
    ax.set_xlabel("number of calibration points")
    ax.set_ylabel("mean leave-one-out 3D error (mm)")
    ax.set_title("Fig. 4: leave-one-out error against the number of calibration points")
    finite = np.concatenate([1e3 * curve.mean(m) for m in curve.methods])
    finite = finite[np.isfinite(finite)]
    if finite.size and finite.max() > 20 * finite.min():
        ax.set_yscale("log")
    ax.grid(True, alpha=0.3)
    ax.legend()
    return [csv_path, save_png(fig, out_dir / "fig4_loo_vs_points.png")]
