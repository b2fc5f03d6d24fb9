"""The wand calibration of a world's rig: record, fit, give it a frame, save.

`calibrate_with_wand(world, seconds=..., wand_length_m=...)`, for any `RigWorld` (simulated or
real; nothing here knows which):

1. the world's own IR sources are switched off (a stray dot makes a camera's frame useless: which
   two dots are the wand is then unknown), and on again at the end;
2. `capture_wand` reads the remotes for `seconds` while someone waves the wand (in simulation the
   caller has `SimWorld.wave_wand` do it), reporting progress and coverage;
3. `wiithrow.vision.wand.calibrate_wand` fits the cameras, starting from the settings' nominal
   focal length and principal point;
4. the frame: the first camera's (default), an L-frame's or the robot's link1
   (`wand_frames`); `before_frame(name)` is called first, so that the caller can have the
   L-frame put down (or, in simulation, put it there);
5. the calibration is saved to `out` when given (the same file as the robot calibration's).

`cancel` stops it at the next read of the remotes (`WandCancelled`: the arm stopped, nothing saved).
"""

from __future__ import annotations

import os
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Literal

import numpy as np

from wiithrow.app.calibration.wand_capture import Progress, capture_wand
from wiithrow.app.calibration.wand_frames import DEFAULT_ROBOT_POSES, lframe_frame, robot_frame
from wiithrow.app.errors import AppError
from wiithrow.app.rig.waiting import Cancel, Cancelled
from wiithrow.app.worlds import RigWorld, nominal_cameras
from wiithrow.vision import StereoCalibration
from wiithrow.vision.wand.calibrate import WandCalibration, calibrate_wand
from wiithrow.vision.wand.frames import FrameFit


class WandCancelled(AppError):
    """The operator stopped the wand calibration; the arm was stopped and nothing was saved."""


#: The frames a wand calibration can be given: the first camera's, an L-frame's, the robot's link1.
Frame = Literal["camera", "lframe", "robot"]
FRAMES: tuple[Frame, ...] = ("camera", "lframe", "robot")


def parse_frame(name: str) -> Frame:
    """The frame called `name`; AppError naming the choices otherwise."""
    for frame in FRAMES:
        if frame == name:
            return frame
    raise AppError(f"unknown frame {name!r}: choose one of {', '.join(FRAMES)}")


@dataclass(frozen=True)
class WandRun:
    """A finished wand calibration: the fit in the first camera's frame with its quality
    (`result`), the calibration in the frame asked for, that frame's fit (None for the first
    camera's) and where it was saved (or None)."""

    result: WandCalibration
    calibration: StereoCalibration
    frame_fit: FrameFit | None
    path: Path | None


def calibrate_with_wand(
    world: RigWorld,
    *,
    seconds: float,
    wand_length_m: float,
    frame: Frame = "camera",
    lframe_lengths_m: tuple[float, float] | None = None,
    robot_poses: int = DEFAULT_ROBOT_POSES,
    out: str | os.PathLike[str] | None = None,
    rng: np.random.Generator | None = None,
    progress: Progress | None = None,
    before_frame: Callable[[str], None] | None = None,
    cancel: Cancel = None,
    show_progress: bool = True,
) -> WandRun:
    """Calibrate the world's rig with a wand (see the module docstring)."""
    frame = parse_frame(frame)
    if frame == "robot" and not world.arm_connected:
        raise AppError("the robot frame needs the arm to move its LED: the settings name no arm driver (arm_driver)")
    rng = rng if rng is not None else np.random.default_rng(0)
    world.connect()
    lit = [name for name, on in world.lit().items() if on]
    for name in lit:
        world.light(name, False)
    try:
        result = calibrate_wand(
            capture_wand(world.rig, world.clock, seconds, progress=progress, cancel=cancel),
            wand_length_m,
            focal_px=world.settings.rig.focal_px,
            center_px=world.settings.rig.center_px,
            names=list(world.camera_names()),
            rng=rng,
        )
        calibration, fit = result.calibration, None
        if frame != "camera" and before_frame is not None:
            before_frame(frame)
        if frame == "lframe":
            calibration, fit = lframe_frame(
                calibration, wand_length_m, world.rig, world.clock, arm_lengths_m=lframe_lengths_m, cancel=cancel
            )
        elif frame == "robot":
            world.light("marker", True)
            calibration, fit, _ = robot_frame(
                calibration,
                wand_length_m,
                world.arm,
                world.arm_model,
                world.rig,
                world.clock,
                nominal_cameras(world.settings.rig),
                poses=robot_poses,
                rng=rng,
                cancel=cancel,
                show_progress=show_progress,
            )
    except Cancelled:
        world.arm.stop()
        raise WandCancelled("wand calibration stopped; the arm was stopped and nothing was saved") from None
    finally:
        world.light("marker", False)
        for name in lit:
            world.light(name, True)
    path = calibration.save(out) if out is not None else None
    return WandRun(result, calibration, fit, path)
