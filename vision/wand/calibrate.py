"""`calibrate_wand`: a rig of 2-4 Wiimotes from a wand waved in front of it.

The steps (each in its own module of `wiithrow.vision.wand`):

1. check the data: 2 or more cameras, a positive length, the LEDs far enough apart in every image
   (`scale.check_separation`), every camera seeing both LEDs in some frames (`chain.check_cameras`),
   enough frames in which two cameras saw both (`MIN_FRAMES`);
2. hold out one-second blocks (`HOLDOUT_FRACTION` of them, seeded) for the quality's held-out
   error; everything below uses the other frames;
3. the first cameras: pairs chained from camera 0, each from the normalised eight-point
   algorithm with the end assignment found by RANSAC, scaled by the wand (`chain`), with the
   nominal intrinsics (`focal_px`, `center_px`);
4. every frame's ends put in one order across cameras by triangulation (`ends.label_frames`);
5. the bundle adjustment (`bundle`) of all intrinsics, poses and wands, over at most `max_frames`
   frames spread evenly over the recording (consecutive frames at 100 Hz are near repeats: in the
   tests 500 frames already give the true cameras' 3D accuracy, and the fit's cost grows with the
   frames); the ends are ordered again with the adjusted cameras and, if that changed the order
   of more than 1 % of the fitted frames, the adjustment runs once more;
6. the wand's directions must turn (`chain.check_motion`), and the quality (`quality.assess`).

The result is a `StereoCalibration` in the first camera's frame (its name, "cam0"), the same file
the robot calibration writes (P = K [R | t] per camera, P scaled so that ||P[2, :3]|| = 1 with the
wand in front), with a sample of the fitted wand ends as each camera's calibration points and the
quality in `meta`; `wiithrow.vision.wand.frames` moves it to an L-frame or to the robot's link1.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from wiithrow.vision.camera import DEFAULT_CENTER_PX, DEFAULT_FOCAL_PX, intrinsic_matrix
from wiithrow.vision.dlt import CalibratedCamera
from wiithrow.vision.errors import CalibrationError, TooFewFramesError
from wiithrow.vision.stereo_calibration import StereoCalibration
from wiithrow.vision.triangulation import triangulate
from wiithrow.vision.wand.bundle import BundleResult, bundle_adjust
from wiithrow.vision.wand.chain import check_cameras, check_motion, initial_rig, stray_sources
from wiithrow.vision.wand.ends import Labels, label_frames
from wiithrow.vision.wand.observations import WandObservations
from wiithrow.vision.wand.quality import WandQuality, assess
from wiithrow.vision.wand.scale import check_separation

#: Frames in which two cameras saw both LEDs, at least (a few seconds of waving).
MIN_FRAMES = 200
#: Frames the bundle adjustment fits, at most (spread over the recording).
DEFAULT_MAX_FRAMES = 1000
#: Share of one-second blocks held out of the fit.
HOLDOUT_FRACTION = 0.1
#: Calibration points kept per camera in the file (a sample of the fitted wand ends).
POINTS_KEPT = 200


@dataclass(frozen=True)
class WandCalibration:
    """A wand calibration: the rig (`calibration`), its quality, the ordered ends (`labels`), the
    held-out frames (N,), the bundle adjustment's result, and the observations it was made from."""

    calibration: StereoCalibration
    quality: WandQuality
    labels: Labels
    heldout: NDArray[np.bool_]
    bundle: BundleResult
    wand_length_m: float
    observations: WandObservations


def heldout_blocks(t: NDArray[np.float64], fraction: float, rng: np.random.Generator) -> NDArray[np.bool_]:
    """Frames (N,) in the one-second blocks drawn to be held out (at least one block when there are
    several, none when `fraction` is 0)."""
    block = np.floor(t - t[0]).astype(np.int64)
    blocks = np.unique(block)
    n = round(fraction * len(blocks))
    if fraction > 0 and len(blocks) > 1:
        n = max(n, 1)
    chosen = rng.choice(blocks, size=min(n, len(blocks) - 1), replace=False) if n else np.zeros(0, np.int64)
    held: NDArray[np.bool_] = np.isin(block, chosen)
    return held


def _spread(frames: NDArray[np.int64], most: int) -> NDArray[np.int64]:
    """At most `most` of `frames`, evenly spaced."""
    if len(frames) <= most:
        return frames
    return frames[np.linspace(0, len(frames) - 1, most).round().astype(np.int64)]


def _adjust(
    labels: Labels,
    fit: NDArray[np.bool_],
    K: NDArray[np.float64],
    R: NDArray[np.float64],
    t: NDArray[np.float64],
    Ps: NDArray[np.float64],
    wand_length_m: float,
    max_frames: int,
) -> BundleResult:
    frames = _spread(np.flatnonzero(labels.usable & fit), max_frames)
    C = labels.pixels.shape[0]
    image = labels.pixels[:, frames].transpose(0, 2, 1, 3).reshape(C, -1, 2)
    ends = triangulate(Ps, image).points.reshape(2, -1, 3).transpose(1, 0, 2)
    good = np.isfinite(ends).all(axis=(1, 2)) & (np.linalg.norm(ends[:, 0] - ends[:, 1], axis=1) > 0)
    return bundle_adjust(labels.pixels, frames[good], K, R, t, ends[good], wand_length_m)


def _cameras(
    result: BundleResult, labels: Labels, names: Sequence[str], image_size: tuple[int, int]
) -> tuple[CalibratedCamera, ...]:
    """Each camera as a `CalibratedCamera`: P, and a sample of the fitted wand ends it saw."""
    cameras = []
    for c, name in enumerate(names):
        rows = np.flatnonzero(result.obs_camera == c)
        keep = rows[np.linspace(0, len(rows) - 1, min(POINTS_KEPT, len(rows))).round().astype(np.int64)]
        world = result.ends[result.obs_frame[keep], result.obs_end[keep]]
        image = labels.pixels[c, result.frames[result.obs_frame[keep]], result.obs_end[keep]]
        residuals = np.linalg.norm(result.residuals_px[keep], axis=1)
        P = result.Ps[c] / np.linalg.norm(result.Ps[c][2, :3])
        cameras.append(
            CalibratedCamera(P, "wand", world, image, residuals, np.ones(len(keep), dtype=bool), image_size, name)
        )
    return tuple(cameras)


def calibrate_wand(
    observations: WandObservations,
    wand_length_m: float,
    *,
    focal_px: float | Sequence[float] = DEFAULT_FOCAL_PX,
    center_px: tuple[float, float] = DEFAULT_CENTER_PX,
    names: Sequence[str] | None = None,
    max_frames: int = DEFAULT_MAX_FRAMES,
    holdout_fraction: float = HOLDOUT_FRACTION,
    rng: np.random.Generator | None = None,
) -> WandCalibration:
    """Calibrate the cameras of `observations` with a wand `wand_length_m` long (see the module
    docstring). `focal_px` (one, or one per camera) and `center_px` start the intrinsics; `rng`
    seeds the RANSAC and the held-out blocks (default: a fixed seed, so results repeat).

    Raises TooFewFramesError, WandNotSeenError, WandLengthError or DegenerateMotionError (all
    `CalibrationError`s) with a message that says what to do."""
    rng = rng if rng is not None else np.random.default_rng(0)
    C = observations.cameras
    names = list(names) if names is not None else [f"cam{c}" for c in range(C)]
    if len(names) != C:
        raise CalibrationError(f"{len(names)} camera names for {C} cameras")
    if not (np.isfinite(wand_length_m) and wand_length_m > 0):
        raise CalibrationError(f"the wand length must be a positive number of metres, got {wand_length_m}")
    pixels = observations.pixels
    check_separation(pixels, names)
    both = observations.both
    check_cameras(both, names, observations.crowded)
    paired = both.sum(axis=0) >= 2
    if paired.sum() < MIN_FRAMES:
        stray = stray_sources(observations.crowded, observations.frames, names)
        raise TooFewFramesError(
            f"only {int(paired.sum())} frames in which two cameras saw both LEDs (at least {MIN_FRAMES}, a few "
            "seconds of waving, are needed; a minute is better): "
            + (stray or "record for longer, inside the cameras' view")
        )
    heldout = heldout_blocks(observations.t, holdout_fraction, rng)
    training = np.where(heldout[None, :, None, None], np.nan, pixels)
    focal = np.broadcast_to(np.asarray(focal_px, dtype=float), (C,))
    K0 = np.stack([intrinsic_matrix(float(f), center_px) for f in focal])
    rig = initial_rig(training, wand_length_m, K0, rng, names)
    labels = label_frames(rig.Ps, pixels, wand_length_m)
    result = _adjust(labels, ~heldout, rig.K, rig.R, rig.t, rig.Ps, wand_length_m, max_frames)
    relabelled = label_frames(result.Ps, pixels, wand_length_m)
    changed = ~np.all(
        np.isclose(relabelled.pixels[:, result.frames], labels.pixels[:, result.frames], equal_nan=True), axis=(0, 2, 3)
    )
    if changed.mean() > 0.01:
        result = _adjust(relabelled, ~heldout, result.K, result.R, result.t, result.Ps, wand_length_m, max_frames)
        relabelled = label_frames(result.Ps, pixels, wand_length_m)
    labels = relabelled
    direction = result.ends[:, 0] - result.ends[:, 1]
    check_motion(direction / np.linalg.norm(direction, axis=1, keepdims=True))
    quality = assess(
        result.Ps,
        labels.pixels,
        labels.usable,
        heldout,
        result.residuals_px,
        result.obs_camera,
        len(result.frames),
        labels.outliers,
        wand_length_m,
        names,
        observations.image_size,
    )
    meta = {
        "source": "wand",
        "wand_length_m": wand_length_m,
        "frames": observations.frames,
        "duration_s": observations.duration_s(),
        "fitted_frames": len(result.frames),
        "fit_s": result.seconds,
        "quality": {k: v for k, v in quality.to_dict().items() if k != "cameras"},
    }
    calibration = StereoCalibration(_cameras(result, labels, names, observations.image_size), names[0], None, meta)
    return WandCalibration(calibration, quality, labels, heldout, result, wand_length_m, observations)
