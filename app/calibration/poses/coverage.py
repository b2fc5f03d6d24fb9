"""What a rig sees of the throwing area: the share of the throw plane in every camera's view."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from wiithrow.vision.camera import WiimoteCamera
from wiithrow.vision.rig import in_common_view


@dataclass(frozen=True)
class RigCoverage:
    """The part of the throw plane (y = 0 of link1: x distance, z height) both cameras see.

    `fraction`: of the grid x in `x_m`, z in `z_m`; `y_half_width`: for each x of `widths_x`, the
    half-width (m) of the common view at z = 0 and z = z_max (the smaller), NaN if unseen.
    """

    x_m: tuple[float, float]
    z_m: tuple[float, float]
    margin_px: float
    fraction: float
    missed: list[tuple[float, float]]
    widths_x: tuple[float, ...]
    y_half_width: tuple[float, ...]


def rig_coverage(
    cameras: Sequence[WiimoteCamera],
    *,
    x_m: tuple[float, float] = (1.0, 2.5),
    z_m: tuple[float, float] = (0.0, 0.5),
    margin_px: float = 20.0,
    steps: tuple[int, int] = (31, 21),
    widths_x: tuple[float, ...] = (1.0, 1.5, 2.0, 2.5),
) -> RigCoverage:
    """Measure which targets (throw plane, floor to table height) the rig sees (see RigCoverage)."""
    xs, zs = np.linspace(*x_m, steps[0]), np.linspace(*z_m, steps[1])
    grid = np.array([[x, 0.0, z] for x in xs for z in zs])
    ok = in_common_view(cameras, grid, margin_px)
    missed = [(float(x), float(z)) for (x, _, z), o in zip(grid, ok) if not o]
    widths = []
    ys = np.linspace(-2.0, 2.0, 801)
    for x in widths_x:
        half = np.inf
        for z in z_m:
            seen = in_common_view(cameras, np.column_stack([np.full_like(ys, x), ys, np.full_like(ys, z)]), margin_px)
            half = min(half, float(min(-ys[seen].min(), ys[seen].max()))) if seen.any() else np.nan
        widths.append(half)
    return RigCoverage(x_m, z_m, margin_px, float(ok.mean()), missed, tuple(widths_x), tuple(widths))
