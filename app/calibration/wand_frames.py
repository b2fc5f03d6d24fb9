"""Giving a wand calibration the frame it will be used in: an L-frame, or the robot's link1.

A wand calibration comes out in its first camera's frame (`wiithrow.vision.wand.calibrate`). Two
procedures measure the points that move it elsewhere (the fits and the checks are
`wiithrow.vision.wand.frames` and `.scale`):

* `lframe_frame`: three LEDs of an L-frame, the only lit IR sources, held still in view of the
  rig; for `seconds` (1 s) each camera's frames with exactly three dots are averaged slot by slot
  (a remote keeps a blob in its slot), the dots are matched across cameras by epipolar geometry
  (`wiithrow.vision.correspondence.Correspondence`) and triangulated; the corner is the origin, the
  longer arm x, the shorter y. With the arms' lengths given, the scale the L-frame implies checks
  the wand's length.
* `robot_frame`: the arm shows the hand's LED at `poses` poses (6 or more) chosen, measured and
  replaced as the robot calibration does (`wiithrow.app.calibration.robot.PoseMeasurer`: FK of the
  measured joints, 10 frames averaged); the wand calibration triangulates them, the rigid fit to
  their FK positions gives link1, and its scale checks the wand's length.

Each returns the moved calibration and the fit (how well the frame is determined: residual per
point, RMS, the implied scale).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import replace

import numpy as np
from numpy.typing import NDArray

from wiithrow.app.calibration.poses import select_poses
from wiithrow.app.calibration.robot import PoseData, PoseMeasurer
from wiithrow.app.errors import AppError
from wiithrow.app.rig.source import MarkerSource
from wiithrow.app.rig.waiting import Cancel, pump
from wiithrow.clock import Clock
from wiithrow.robot import Arm, ArmModel
from wiithrow.vision import StereoCalibration
from wiithrow.vision.camera import WiimoteCamera
from wiithrow.vision.correspondence import Correspondence
from wiithrow.vision.wand.frames import FrameFit, lframe_fit, robot_fit, transform_calibration
from wiithrow.vision.wand.scale import check_scale

#: Arm poses the robot frame uses by default (six are the fewest; a few more average the noise).
DEFAULT_ROBOT_POSES = 8


def still_dots(
    rig: MarkerSource, clock: Clock, seconds: float, count: int, cancel: Cancel = None
) -> NDArray[np.float64]:
    """Each camera's `count` dots (C, 4, 2) averaged slot by slot over `seconds` of frames that show
    exactly `count` dots (NaN in the other slots). AppError when a camera never showed them."""
    start = clock.now()
    pump(clock, rig, seconds, cancel=cancel)
    out = np.full((len(rig.camera_names), 4, 2), np.nan)
    for c in range(len(rig.camera_names)):
        frames = [f for f in rig.recent(c, 100) if f.t > start and int(f.visible.sum()) == count]
        if not frames:
            raise AppError(
                f"cam{c} did not see exactly {count} IR sources in {seconds:g} s: put the L-frame where every "
                "remote sees its three LEDs, and switch off other IR sources"
            )
        out[c] = np.mean([f.dots for f in frames], axis=0)
    return out


def lframe_frame(
    calibration: StereoCalibration,
    wand_length_m: float,
    rig: MarkerSource,
    clock: Clock,
    *,
    arm_lengths_m: tuple[float, float] | None = None,
    seconds: float = 1.0,
    cancel: Cancel = None,
) -> tuple[StereoCalibration, FrameFit]:
    """The calibration in the frame of the L-frame the rig sees now (see the module docstring)."""
    dots = still_dots(rig, clock, seconds, 3, cancel)
    markers = Correspondence(calibration.Ps).match(dots)
    if len(markers.points) != 3:
        raise AppError(
            f"the L-frame's three LEDs matched as {len(markers.points)} points across the cameras: "
            "every remote must see all three"
        )
    fit = lframe_fit(markers.points, arm_lengths_m)
    if arm_lengths_m is not None:
        check_scale(fit.scale, wand_length_m, "the L-frame of known size")
    return transform_calibration(calibration, fit), fit


def robot_frame(
    calibration: StereoCalibration,
    wand_length_m: float,
    arm: Arm,
    arm_model: ArmModel,
    rig: MarkerSource,
    clock: Clock,
    cameras: Sequence[WiimoteCamera],
    *,
    poses: int = DEFAULT_ROBOT_POSES,
    rng: np.random.Generator | None = None,
    cancel: Cancel = None,
    show_progress: bool = True,
) -> tuple[StereoCalibration, FrameFit, PoseData]:
    """The calibration in link1 from the hand's LED at `poses` arm poses (see the module
    docstring); `cameras`: the nominal ones, which choose poses the rig should see."""
    rng = rng if rng is not None else np.random.default_rng(0)
    measurer = PoseMeasurer(arm, arm_model, rig, clock, cameras, cancel=cancel, rng=rng)
    start = measurer.marker_link1(arm.state().q)
    plan = select_poses(arm_model, cameras, poses, rng, start=start)
    data = measurer.run(plan, poses, show_progress=show_progress)
    fit = robot_fit(calibration.triangulate(data.image).points, data.positions)
    check_scale(fit.scale, wand_length_m, "the robot's forward kinematics")
    return replace(transform_calibration(calibration, fit), arm=arm_model.name), fit, data
