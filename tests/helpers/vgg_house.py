"""Loader for the Oxford VGG "Model House" data in ../shared/data/vgg-house (real photographs with
ground-truth cameras). Tests use `load_house()` and skip, with the reason, when the data is absent.
"""

from __future__ import annotations

from pathlib import Path
from typing import NamedTuple

import numpy as np
import pytest

#: The checkout's root is two levels up (tests/helpers/); the shared folder sits beside the checkout.
REPOSITORY = Path(__file__).resolve().parents[2]
HOUSE = REPOSITORY.parent / "shared" / "data" / "vgg-house"
VIEWS = 10


class House(NamedTuple):
    points: np.ndarray  # (672, 3) ground-truth 3D points
    Ps: np.ndarray  # (10, 3, 4) ground-truth cameras
    image: np.ndarray  # (10, 672, 2) pixels, NaN where a view does not see the point


def load_house() -> House:
    """The house data, or pytest.skip with the reason when the folder is absent."""
    if not (HOUSE / "house.p3d").exists():
        pytest.skip(
            f"real data not available: {HOUSE} is absent (put the shared folder beside the checkout: docs/architecture.md, 'Tests')"
        )
    points = np.loadtxt(HOUSE / "house.p3d")
    Ps = np.stack([np.loadtxt(HOUSE / f"house.{v:03d}.P") for v in range(VIEWS)])
    corners = [np.loadtxt(HOUSE / f"house.{v:03d}.corners") for v in range(VIEWS)]
    image = np.full((VIEWS, len(points), 2), np.nan)
    for i, line in enumerate((HOUSE / "house.nview-corners").read_text().splitlines()):
        for v, token in enumerate(line.split()[:VIEWS]):
            if token != "*":
                image[v, i] = corners[v][int(token)]
    return House(points, Ps, image)
