"""Assembling a simulated session for the command line: the world, its calibration, the library."""

from __future__ import annotations

import sys

import numpy as np

from wiithrow.app.session.session import Session
from wiithrow.app.settings import Settings
from wiithrow.app.throws.library_file import load_library
from wiithrow.app.worlds.simulated import SimWorld
from wiithrow.throwing import ThrowLibrary
from wiithrow.vision import StereoCalibration


def simulated_session(
    *,
    seed: int = 0,
    settings: Settings | None = None,
    calibration: str | None = None,
    library: str | ThrowLibrary | None = None,
    need_library: bool = True,
    poses: int = 30,
    quiet: bool = False,
) -> Session:
    """A session on a simulated world: calibrated from `calibration` (a file) or by the robot now."""
    world = SimWorld(settings, seed=seed)
    lib = library if isinstance(library, ThrowLibrary) else (load_library(library) if need_library else None)
    session = Session(world, library=lib, rng=np.random.default_rng(seed + 1))
    if calibration:
        session.use_calibration(StereoCalibration.load(calibration))
    else:
        if not quiet:
            print(f"calibrating the simulated rig with the robot ({poses} poses)...", file=sys.stderr)
        session.calibrate(poses, show_progress=not quiet)
    world.advance(0.2)
    return session
