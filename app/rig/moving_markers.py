"""Moving IR markers for simulations: four markers on crossing paths in front of the rig.

Positions are in `link1` (the rig's mount frame), in the default rig's common field of view at
0.8-1.1 m. Markers 0 and 1 swing along y in opposite directions at different depths, so their dots
cross in both images while they stay 0.2 m apart in depth; markers 2 and 3 swing along z, crossing
each other in 3D with 4 cm between their paths. Each marker moves as c + a sin(w t + phi) d with
one w for all, so the fastest (largest a) peaks at a w = `speed` (2 m/s is a fast hand).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

CENTERS = np.array([[0.80, 0.0, 0.30], [1.00, 0.0, 0.34], [0.90, -0.05, 0.30], [0.90, -0.01, 0.30]])
DIRECTIONS = np.array([[0.0, 1.0, 0.0], [0.0, -1.0, 0.0], [0.0, 0.0, 1.0], [0.0, 0.0, -1.0]])
AMPLITUDES = np.array([0.15, 0.20, 0.12, 0.12])
PHASES = np.array([0.0, 0.0, 0.5, 0.5])


def crossing_paths(t: float | NDArray[np.float64], speed: float = 2.0) -> NDArray[np.float64]:
    """Marker positions (4, 3) at time t, or (T, 4, 3) for an array of times (metres, link1)."""
    t = np.asarray(t, dtype=float)
    omega = speed / AMPLITUDES.max()
    s = np.sin(omega * t[..., None] + PHASES)  # (..., 4)
    return CENTERS + (AMPLITUDES * s)[..., None] * DIRECTIONS


def crossing_velocities(t: float | NDArray[np.float64], speed: float = 2.0) -> NDArray[np.float64]:
    """Marker velocities (4, 3) (m/s) at time t."""
    t = np.asarray(t, dtype=float)
    omega = speed / AMPLITUDES.max()
    c = omega * np.cos(omega * t[..., None] + PHASES)
    return (AMPLITUDES * c)[..., None] * DIRECTIONS
