"""Helpers shared by the app tests: where to put a target."""

from __future__ import annotations

import numpy as np


def target_at(distance: float, bearing: float, height: float) -> np.ndarray:
    """A target in base at `distance` from joint 1's axis, `bearing` rad, `height` m."""
    return np.array([distance * np.cos(bearing), distance * np.sin(bearing), height])
