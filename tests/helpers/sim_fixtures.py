"""Simulated worlds and sessions shared by the app tests (built once per test module)."""

from __future__ import annotations

import numpy as np

from wiithrow.app.session.session import Session
from wiithrow.app.worlds.simulated import SimWorld
from wiithrow.vision import StereoCalibration
from wiithrow.vision.dlt import CalibratedCamera


def true_calibration(world: SimWorld) -> StereoCalibration:
    """The simulated cameras' true projection matrices as a calibration (no calibration error)."""
    cameras = tuple(
        CalibratedCamera(c.P, "true", np.zeros((0, 3)), np.zeros((0, 2)), np.zeros(0), np.zeros(0, bool), name=c.name)
        for c in world.cameras
    )
    return StereoCalibration(cameras, "link1")


def true_session(seed: int = 0, **world_args) -> Session:
    """A session whose rig tracks with the true cameras, using the shipped library."""
    world = SimWorld(seed=seed, **world_args)
    session = Session(world, rng=np.random.default_rng(seed + 1))
    session.use_calibration(true_calibration(world))
    world.advance(0.2)
    return session


def target_at(distance: float, bearing: float, height: float) -> np.ndarray:
    """A target in base at `distance` from joint 1's axis, `bearing` rad, `height` m."""
    return np.array([distance * np.cos(bearing), distance * np.sin(bearing), height])
