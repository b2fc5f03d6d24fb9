"""The LEDs of the MuJoCo world in the true link1, as rows of plain Python floats: what the simulated
remotes see, 200 times per simulated second (`lab.MujocoLab.led_rows_in_link1`).

`rows_in_link1` is R^T (p - o) for each shown LED (NaN rows for the others), with (R, o) link1's
pose: the body joint 1 turns (R_b, o_b) taken back by its nominal pose at q = 0 (R0, p0), R = R_b
R0^T, o = o_b - R p0 (`model.link1_pose`). Each sum is taken in index order, where numpy's small
matrix products cost a microsecond or two each (and, through BLAS's fused multiply-adds, may round
a last bit differently: a difference of 1e-16 m, which could change a remote's pixel only at an
exact .5 tie after the noise).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence

import numpy as np
from numpy.typing import NDArray

from wiithrow.vision.wiimote.sim_reports import SourceRows

#: link1's nominal pose at q = 0 as floats: (R0's three rows, p0); None: the identity.
Link1Offset = tuple[list[float], list[float], list[float], list[float]] | None


def rows_in_link1(
    pose: Sequence[float],
    offset: Link1Offset,
    site_xpos: NDArray[np.float64],
    sites: Mapping[str, int],
    names: tuple[str, ...],
    shown: tuple[bool, ...],
) -> SourceRows:
    """The LEDs `names` in link1 (module docstring): `pose` is the body joint 1 turns, its origin (3)
    and its orientation (9, row-major), then, from the ring of a past step (`cycle.POSE_COLUMNS`),
    the hand's LED (3), which is taken instead of its site's position now; `sites`: each LED's site."""
    ox, oy, oz, b00, b01, b02, b10, b11, b12, b20, b21, b22, *hand = pose
    if offset is None:
        r00, r01, r02, r10, r11, r12, r20, r21, r22 = b00, b01, b02, b10, b11, b12, b20, b21, b22
    else:  # R[r][c] = sum_k R_b[r][k] R0[c][k];  o = o_b - R p0
        (a00, a01, a02), (a10, a11, a12), (a20, a21, a22), (px, py, pz) = offset
        r00, r01, r02 = (
            b00 * a00 + b01 * a01 + b02 * a02,
            b00 * a10 + b01 * a11 + b02 * a12,
            b00 * a20 + b01 * a21 + b02 * a22,
        )
        r10, r11, r12 = (
            b10 * a00 + b11 * a01 + b12 * a02,
            b10 * a10 + b11 * a11 + b12 * a12,
            b10 * a20 + b11 * a21 + b12 * a22,
        )
        r20, r21, r22 = (
            b20 * a00 + b21 * a01 + b22 * a02,
            b20 * a10 + b21 * a11 + b22 * a12,
            b20 * a20 + b21 * a21 + b22 * a22,
        )
        ox -= r00 * px + r01 * py + r02 * pz
        oy -= r10 * px + r11 * py + r12 * pz
        oz -= r20 * px + r21 * py + r22 * pz
    nan = math.nan
    rows: list[tuple[float, float, float]] = []
    for row, name in enumerate(names):
        if not shown[row]:
            rows.append((nan, nan, nan))
            continue
        x, y, z = hand if hand and name == "marker" else site_xpos[sites[name]].tolist()
        x, y, z = x - ox, y - oy, z - oz
        rows.append((r00 * x + r10 * y + r20 * z, r01 * x + r11 * y + r21 * z, r02 * x + r12 * y + r22 * z))
    return tuple(rows)
