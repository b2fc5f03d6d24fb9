"""The robot-driven calibration of the simulated rig, and the last one kept for the next run.

`calibrate_simulated_rig` runs the paper's procedure (`wiithrow.app.calibration.robot`) in a
fresh simulated world (the kinematic one, or MuJoCo's): what `wiithrow calibrate --robot --sim` does.

`simulated_rig_calibration` is what `wiithrow throw --sim` and `train --sim` measure with when no
`--calibration` is given. A robot calibration takes a minute of simulated time, and it is the
same every time for the same settings, seed and number of poses, so the last one is kept in the
user's cache folder (`cache_dir()`: $WIITHROW_CACHE_DIR, else $XDG_CACHE_HOME/wiithrow, else
~/.cache/wiithrow) and reused while it is still valid: the file reads and checks as a
calibration (`StereoCalibration.load`), was made for the same key (the settings, the seed, the
poses, the method, the kinematics (identified or nominal) and wiithrow's version) and fits the rig. Each run says which it did. The
calibration runs in a world of its own (seeded `seed + CALIBRATION_SEED_OFFSET`, so that its
pixel noise is not the noise the throws will see), so a run that reuses the kept calibration
gives exactly the result of the run that made it. Keeping it is a convenience: a cache folder
that cannot be written is said and otherwise ignored.
"""

from __future__ import annotations

import hashlib
import json
import os
from collections.abc import Callable
from pathlib import Path

import numpy as np

from wiithrow import __version__
from wiithrow.app.calibration.kinematic import Kinematics
from wiithrow.app.calibration.robot import DEFAULT_POSES, RobotCalibration, RobotCalibrationOptions, calibrate_in_world
from wiithrow.app.errors import AppError
from wiithrow.app.settings import Settings
from wiithrow.app.worlds.base import RigWorld, check_calibration_fits
from wiithrow.app.worlds.named import make_world
from wiithrow.vision import StereoCalibration, VisionError
from wiithrow.vision.dlt import Method
from wiithrow.vision.files import atomic_write_text

#: The seed of the calibration's own world is the run's seed plus this.
CALIBRATION_SEED_OFFSET = 1_000_000


def calibrate_simulated_rig(
    settings: Settings,
    *,
    seed: int,
    n_poses: int,
    method: Method = "refined",
    kinematics: Kinematics = "identified",
    show_progress: bool = True,
    meta: dict | None = None,
    world_name: str = "kinematic",
) -> tuple[RobotCalibration, RigWorld]:
    """The robot-driven calibration in a fresh simulated world (`world_name`, one of
    `wiithrow.app.worlds.named.WORLDS`, seeded `seed`, its marker LED lit). Returns the result
    and the world (for comparisons with the true cameras); close the world. A MuJoCo world's arm
    is the same arm in every world made from the same settings (its tolerances are seeded by
    `settings.mujoco.seed`, not by `seed`)."""
    world = make_world(world_name, settings, seed=seed)
    world.light("marker")
    world.connect()
    try:
        options = RobotCalibrationOptions(
            n_poses=n_poses,
            method=method,
            kinematics=kinematics,
            show_progress=show_progress,
            meta={"simulated": True, "seed": seed, "world": world_name, **(meta or {})},
        )
        result = calibrate_in_world(world, options, rng=np.random.default_rng(seed))
    except BaseException:
        world.close()
        raise
    return result, world


def cache_dir() -> Path:
    """Where the last calibration of the simulated rig is kept (module docstring)."""
    if os.environ.get("WIITHROW_CACHE_DIR"):
        return Path(os.environ["WIITHROW_CACHE_DIR"])
    base = os.environ.get("XDG_CACHE_HOME") or str(Path.home() / ".cache")
    return Path(base) / "wiithrow"


def cache_key(
    settings: Settings,
    seed: int,
    poses: int,
    method: str,
    world: str = "kinematic",
    kinematics: str = "identified",
) -> str:
    """What a kept calibration must have been made for (a hash of it)."""
    what = {
        "settings": settings.to_dict(),
        "seed": seed,
        "poses": poses,
        "method": method,
        "kinematics": kinematics,
        "world": world,
        "version": __version__,
    }
    return hashlib.sha256(json.dumps(what, sort_keys=True).encode()).hexdigest()[:16]


def simulated_rig_calibration(
    settings: Settings,
    *,
    seed: int,
    poses: int = DEFAULT_POSES,
    method: Method = "refined",
    kinematics: Kinematics = "identified",
    reuse: bool = True,
    say: Callable[[str], None] = lambda message: None,
    show_progress: bool = True,
    world: str = "kinematic",
) -> StereoCalibration:
    """The kept calibration of the simulated rig when still valid (and `reuse`), else a new one,
    kept for the next run (module docstring). `say` gets one line saying which."""
    key = cache_key(settings, seed, poses, method, world, kinematics)
    path = cache_dir() / f"sim-calibration-{key}.json"
    if reuse and path.exists():
        why = _invalid(path, key, settings)
        if why is None:
            say(
                f"reusing the simulated rig's calibration kept in {path} (same settings, seed {seed}, "
                f"{poses} poses; --recalibrate makes a new one)"
            )
            return StereoCalibration.load(path)
        say(f"not reusing {path}: {why}")
    say(f"calibrating the simulated rig with the robot ({poses} poses, about {poses * 1.2:.0f} s of the arm's time)...")
    result, calibrated = calibrate_simulated_rig(
        settings,
        seed=seed + CALIBRATION_SEED_OFFSET,
        n_poses=poses,
        method=method,
        kinematics=kinematics,
        show_progress=show_progress,
        meta={"cache_key": key, "run_seed": seed},
        world_name=world,
    )
    calibrated.close()
    try:
        atomic_write_text(path, result.calibration.to_text())
        say(f"kept it in {path} for the next runs")
    except OSError as exc:
        say(f"could not keep it in {path} ({exc.strerror or exc}); the next run calibrates again")
    return result.calibration


def _invalid(path: Path, key: str, settings: Settings) -> str | None:
    """Why the kept calibration at `path` cannot be reused, or None."""
    try:
        calibration = StereoCalibration.load(path)
    except VisionError as exc:
        return str(exc)
    if calibration.meta.get("cache_key") != key:
        return "it was made for other settings"
    try:
        check_calibration_fits(calibration, remotes=settings.rig.count, frame="link1")
    except AppError as exc:
        return str(exc)
    return None
