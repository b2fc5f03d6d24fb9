"""The one way to build a session on the simulated world: for the command line, the dashboard's
demo, the benchmarks, the studies and the tests.

`simulated_session(...)` makes a simulated world (`world="kinematic"`: the `SimWorld`, whose arm
and ball are the planner's own models, fast, what most tests want; `world="mujoco"`: the
`MujocoWorld`, physics the planner does not know, through the hardware interfaces), on a
simulated clock or in real time for the dashboard, a `Session` on it with the throw library, and
calibrates the rig as asked:

* `calibration="robot"`: the paper's robot-driven calibration (`poses` poses, about a minute of
  simulated time; a progress bar on a terminal unless `quiet`), run in a world of its own
  (`wiithrow.app.calibration.simulated`); with `reuse_calibration` the last one kept for these
  settings, seed and poses is used when still valid, and `say` is told which;
* `calibration="true"`: the simulated cameras' true projection matrices (no calibration error:
  what a test of something else wants);
* `calibration=None`: none (the dashboard's operator presses Calibrate);
* a path or a `StereoCalibration`: that calibration (a robot's or a wand's, in link1 or in the
  first camera's frame: `wiithrow.app.worlds.base.on_link1`); the simulated rig gets as many
  remotes as it has cameras.

`cameras` (2 to 4) sets the number of simulated remotes, placed by the settings
(`Settings.with_cameras`).

The library is a path, a `ThrowLibrary`, or None for the library folder's version in use (`store`,
`wiithrow.app.throws.library_store`), else the one shipped with the package (loaded by the session
when it is first needed, so that training never reads it). With `learn` (the default) measured
throws join it (`Session`); with a `store` each update is a version of it (a library given by path
is kept there first, `library_folder.starting_library`; a `ThrowLibrary` is its `version` there), without one the learning stays in memory
and no file is written. Seeds: the world draws
from `seed`, the session (pose choice, throw noise) from `seed + 1`. Every input (the library, a
calibration file) is read and checked before the calibration starts.

`DEMO_TARGET_XZ` / `demo_target_base`: where `wiithrow demo` puts the simulated target.
"""

from __future__ import annotations

import os
import sys
from collections.abc import Callable
from typing import Literal

import numpy as np
from numpy.typing import NDArray

from wiithrow.app.calibration.robot import DEFAULT_POSES
from wiithrow.app.calibration.simulated import simulated_rig_calibration
from wiithrow.app.rig.waiting import pump
from wiithrow.app.session.library_folder import starting_library
from wiithrow.app.session.session import Session
from wiithrow.app.settings import Settings
from wiithrow.app.throws.library_file import load_library
from wiithrow.app.throws.library_store import LibraryStore, VersionInfo
from wiithrow.app.worlds.named import make_world
from wiithrow.throwing import ThrowLibrary
from wiithrow.vision import StereoCalibration

CalibrationSource = Literal["robot", "true"] | str | os.PathLike[str] | StereoCalibration | None

#: Where the demo puts the simulated target: (distance, height) in the throw plane (inside the
#: trained area x 1.0-1.6 m, z 0-0.4 m) and its azimuth from the arm's x axis (rad), in the
#: rig's view at the home pose, so that "Track target" has something to do.
DEMO_TARGET_XZ = (1.3, 0.2)
DEMO_TARGET_AZIMUTH = 0.2


def demo_target_base(
    azimuth: float = DEMO_TARGET_AZIMUTH, xz: tuple[float, float] = DEMO_TARGET_XZ
) -> NDArray[np.float64]:
    """The demo target in `base` (m): distance xz[0] from the joint-1 axis at `azimuth`, height xz[1]."""
    return np.array([xz[0] * np.cos(azimuth), xz[0] * np.sin(azimuth), xz[1]])


def simulated_session(
    *,
    seed: int = 0,
    settings: Settings | None = None,
    calibration: CalibrationSource = "robot",
    library: str | os.PathLike[str] | ThrowLibrary | None = None,
    realtime: bool = False,
    poses: int = DEFAULT_POSES,
    quiet: bool = False,
    reuse_calibration: bool = False,
    say: Callable[[str], None] | None = None,
    cameras: int | None = None,
    world: str = "kinematic",
    learn: bool = True,
    store: LibraryStore | None = None,
    version: VersionInfo | None = None,
) -> Session:
    """A session on a fresh simulated world, calibrated as asked (see the module docstring)."""
    settings = settings or Settings()
    if (
        calibration is not None
        and not isinstance(calibration, StereoCalibration)
        and calibration not in ("robot", "true")
    ):
        calibration = StereoCalibration.load(calibration)
    if cameras is None and isinstance(calibration, StereoCalibration):
        cameras = len(calibration.cameras)
    if cameras is not None:
        settings = settings.with_cameras(cameras)
    built = make_world(world, settings, seed=seed, realtime=realtime)
    if store is not None and not isinstance(library, ThrowLibrary):
        tell = say or (lambda message: print(message, file=sys.stderr))
        lib, version = starting_library(store, library, built.arm_model.name, tell)
    else:
        lib = library if isinstance(library, ThrowLibrary) or library is None else load_library(library)
    session = Session(
        built, library=lib, rng=np.random.default_rng(seed + 1), learn=learn, store=store, version=version
    )
    if calibration is None:
        return session
    if isinstance(calibration, StereoCalibration):
        session.use_calibration(calibration)
    elif calibration == "true":
        session.use_calibration(built.true_calibration())
    elif calibration == "robot":
        tell = say or (lambda message: print(message, file=sys.stderr))
        robot = simulated_rig_calibration(
            settings,
            seed=seed,
            poses=poses,
            reuse=reuse_calibration,
            say=(lambda message: None) if quiet else tell,
            show_progress=not quiet,
            world=world,
        )
        session.use_calibration(robot)
    if not realtime:
        built.connect()
        pump(built.clock, built.rig, 0.2, step_s=0.001)  # the tracker confirms what the rig sees
    return session
