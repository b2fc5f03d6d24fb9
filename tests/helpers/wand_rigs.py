"""Rigs of 2-4 simulated Wiimotes for the wand calibration's tests, each unlike the demo's (two
remotes side by side on the robot, looking the same way): a wide converging pair, an arc of three
at different heights, four in the corners of a room. Frame "room", metres, z up; each rig says the
depths (from a camera) where a person would wave the wand."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from wiithrow.vision.camera import WiimoteCamera
from wiithrow.vision.rig import points_in_view


@dataclass(frozen=True)
class Rig:
    name: str
    cameras: list[WiimoteCamera]
    depth_m: tuple[float, float]

    def points(self, count: int, rng: np.random.Generator) -> np.ndarray:
        """Points (N, 3) where the wand is waved: two or more cameras see them 60 px inside."""
        return points_in_view(self.cameras, count, rng, depth_m=self.depth_m, margin_px=60.0, min_cameras=2)


def _looking_at(positions, target, focal_px=1300.0) -> list[WiimoteCamera]:
    target = np.asarray(target, dtype=float)
    return [
        WiimoteCamera.at(p, target - np.asarray(p, dtype=float), focal_px=focal_px, frame="room", name=f"cam{i}")
        for i, p in enumerate(positions)
    ]


def wide_pair() -> Rig:
    """Two remotes 0.8 m apart, 1 m high, turned towards a point 1.8 m ahead."""
    return Rig("wide pair", _looking_at([(0.0, 0.4, 1.0), (0.0, -0.4, 1.0)], (1.8, 0.0, 0.9)), (1.0, 2.2))


def arc_of_three() -> Rig:
    """Three remotes on an arc of radius 2.2 m, at 1.5, 1.0 and 1.3 m, looking at (0, 0, 1)."""
    angles = np.radians([-40.0, 0.0, 40.0])
    heights = [1.5, 1.0, 1.3]
    positions = [(-2.2 * np.cos(a), 2.2 * np.sin(a), h) for a, h in zip(angles, heights)]
    return Rig("arc of three", _looking_at(positions, (0.0, 0.0, 1.0)), (1.5, 2.8))


def four_corners() -> Rig:
    """Four remotes in the corners of a 3 m square room, 2 m high, looking at (0, 0, 1)."""
    positions = [(1.5, 1.5, 2.0), (-1.5, 1.5, 2.0), (-1.5, -1.5, 2.0), (1.5, -1.5, 2.0)]
    return Rig("four corners", _looking_at(positions, (0.0, 0.0, 1.0)), (1.8, 3.0))
