"""Which dot is which end: found without cameras (RANSAC over the unknown order) and with them."""

import numpy as np
import pytest

from tests.helpers.wand_rigs import arc_of_three, wide_pair
from wiithrow.vision.errors import TooFewFramesError
from wiithrow.vision.wand.ends import label_frames, swap_ransac
from wiithrow.vision.wand.relative_pose import normalised
from wiithrow.vision.wand.waver import wave_wand


def true_order(observations, truth, cameras):
    """(C, N): 0 where dot a is the wand's end 0, 1 where it is end 1, -1 where a was not seen."""
    out = np.full((observations.cameras, observations.frames), -1)
    for c, camera in enumerate(cameras):
        a = observations.pixels[c, :, 0]
        d = np.stack([np.linalg.norm(a - camera.project(truth.ends[:, e]), axis=1) for e in range(2)], axis=1)
        seen = np.isfinite(a).all(axis=1)
        out[c, seen] = np.argmin(d[seen], axis=1)
    return out


@pytest.fixture(scope="module")
def shuffled():
    rig = wide_pair()
    observations, truth = wave_wand(rig.cameras, 15, np.random.default_rng(10), shuffle=True, depth_m=rig.depth_m)
    return rig, observations, truth


def test_ransac_finds_the_order_of_every_decided_frame_from_shuffled_dots(shuffled):
    rig, observations, truth = shuffled
    both = observations.both.all(axis=0)
    x = [normalised(observations.pixels[c, both], rig.cameras[c].K) for c in range(2)]
    pair = swap_ransac(x[0], x[1], np.random.default_rng(0), focal_px=1300.0)
    order = true_order(observations, truth, rig.cameras)[:, both]
    truly_swapped = order[0] != order[1]
    assert pair.decided.mean() > 0.9  # most frames are not in an epipolar plane
    assert np.array_equal(pair.swap[pair.decided].astype(bool), truly_swapped[pair.decided])
    assert pair.inliers.mean() > 0.95


def test_too_few_shared_frames_are_refused(shuffled):
    rig, observations, _ = shuffled
    x = normalised(observations.pixels[0, :10], rig.cameras[0].K)
    with pytest.raises(TooFewFramesError, match="both cameras saw both LEDs"):
        swap_ransac(x, x, np.random.default_rng(0), focal_px=1300.0)


def test_with_the_cameras_every_usable_frame_gets_one_order_in_all_three():
    rig = arc_of_three()
    observations, truth = wave_wand(rig.cameras, 10, np.random.default_rng(11), shuffle=True, depth_m=rig.depth_m)
    Ps = np.stack([c.P for c in rig.cameras])
    labels = label_frames(Ps, observations.pixels, 0.3)
    relabelled = type(observations)(observations.t, labels.pixels)
    order = true_order(relabelled, truth, rig.cameras)
    usable = labels.usable
    seen = order[:, usable] >= 0
    agree = [np.all(column[s] == column[s][0]) for column, s in zip(order[:, usable].T, seen.T)]
    assert usable.mean() > 0.7 and all(agree)
    assert np.nanmax(np.abs(labels.length_m[usable] - 0.3)) < 0.03


def identity(camera, dot, ends):
    """Which true end (0 or 1) a dot (2,) is the image of."""
    return int(np.argmin([np.linalg.norm(dot - camera.project(end[None])[0]) for end in ends]))


def test_a_single_dot_joins_the_end_it_belongs_to():
    rig = arc_of_three()
    observations, truth = wave_wand(rig.cameras, 5, np.random.default_rng(12), depth_m=rig.depth_m)
    Ps = np.stack([c.P for c in rig.cameras])
    pixels = observations.pixels.copy()
    frames = np.flatnonzero(observations.both.all(axis=0))[:50]
    pixels[2, frames, 0] = pixels[2, frames, 1]  # camera 2 saw only the dot it reported second
    pixels[2, frames, 1] = np.nan
    labels = label_frames(Ps, pixels, 0.3)
    kept = np.isfinite(labels.pixels[2, frames, :, 0])  # (frames, 2): which end holds the dot
    assert kept.sum(axis=1).max() == 1 and kept.any(axis=1).mean() > 0.9
    cam0, cam2 = rig.cameras[0], rig.cameras[2]
    for frame, where in zip(frames, kept):
        if where.any():
            end = int(np.argmax(where))
            ends = truth.ends[frame]
            assert identity(cam2, labels.pixels[2, frame, end], ends) == identity(
                cam0, labels.pixels[0, frame, end], ends
            )
