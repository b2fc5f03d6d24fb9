"""Simulated Wiimote rigs and points in their common field of view.

`stereo_rig` places C cameras side by side along the frame's y axis, all looking along +x (turned
by `yaw` about z) and pitched down by `pitch`: the layout of the paper's rig and of the default
world (two remotes 0.25 m apart near shoulder height). With `converge_m` > 0 each camera is also
turned about z towards the point that far ahead of the rig's centre (yaw_i = -atan2(dy_i,
converge_m) for a camera dy_i to the side), so that three or four remotes in a row still share a
view. `in_common_view` tells which points every
camera of a rig sees (`point_in_common_view`: the same for one point, in plain floats, where a
caller asks point by point); `points_in_common_view` draws such points, at depths in a given range, for
calibration and test sets; `points_in_view` those that some of them see (where a wand is waved).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from numpy.typing import ArrayLike, NDArray

from wiithrow.vision.camera import DEFAULT_CENTER_PX, DEFAULT_FOCAL_PX, MIN_DEPTH_M, WiimoteCamera, pitched_forward
from wiithrow.vision.errors import VisionError
from wiithrow.vision.geometry import homogeneous


def stereo_rig(
    *,
    center: ArrayLike = (0.0, 0.0, 0.35),
    baseline: float = 0.25,
    count: int = 2,
    pitch_down_rad: float = np.deg2rad(5.0),
    yaw_rad: float = 0.0,
    toe_in_rad: float = 0.0,
    converge_m: float = 0.0,
    focal_px: float = DEFAULT_FOCAL_PX,
    center_px: tuple[float, float] = DEFAULT_CENTER_PX,
    frame: str = "link1",
) -> list[WiimoteCamera]:
    """`count` cameras spaced `baseline` apart along y around `center`, looking along +x.

    cam0 is on the +y side (the left one as seen from behind the rig), cam1 next to it towards -y,
    and so on. `toe_in_rad` turns each camera towards the rig's middle; `converge_m` > 0 turns each
    towards the point `converge_m` ahead of `center`.
    """
    c = np.asarray(center, dtype=float)
    offsets = (np.arange(count) - (count - 1) / 2.0)[::-1] * baseline
    cameras = []
    for i, dy in enumerate(offsets):
        yaw = yaw_rad - np.sign(dy) * toe_in_rad - (np.arctan2(dy, converge_m) if converge_m > 0 else 0.0)
        position = c + np.array([-np.sin(yaw_rad), np.cos(yaw_rad), 0.0]) * dy
        cameras.append(
            WiimoteCamera.at(
                position,
                pitched_forward(pitch_down_rad, yaw),
                focal_px=focal_px,
                center_px=center_px,
                frame=frame,
                name=f"cam{i}",
            )
        )
    return cameras


def in_common_view(cameras: Sequence[WiimoteCamera], points: ArrayLike, margin_px: float = 20.0) -> NDArray[np.bool_]:
    """Which points (N, 3) every camera sees in front of it and `margin_px` inside its image:

        seen_i = AND over cameras c of  [ depth_ci > MIN_DEPTH_M  and  margin <= u_ci <= width - 1 - margin
                                          and  margin <= v_ci <= height - 1 - margin ]

    with (u, v) from `WiimoteCamera.project` (NaN behind the camera) and the bounds of `in_view`.
    """
    X = np.asarray(points, dtype=float).reshape(-1, 3)
    seen = np.ones(X.shape[0], dtype=bool)
    for camera in cameras:
        seen &= camera.in_view(camera.project(X), margin_px)
    return seen


#: How near (px) an image's edge, or (m) the camera's minimum depth, `point_in_common_view` leaves
#: the decision to `in_common_view`: its own arithmetic (P X, in another order than R X + t then K)
#: differs from it by rounding, about 1e-12 px at these sizes, never by this much.
EDGE_TOLERANCE = 1e-6


def point_in_common_view(cameras: Sequence[WiimoteCamera], point: ArrayLike, margin_px: float = 20.0) -> bool:
    """`in_common_view` of one point (3,), the same decision about ten times faster: for each
    camera, w = P_3 . [X, 1] (the depth, for a pinhole K) and (u, v) = (P_1 . [X, 1], P_2 . [X, 1]) / w
    in plain floats; a point clearly off any camera's image is not seen, one clearly on every image
    is; within `EDGE_TOLERANCE` of an edge (or a camera whose K is not a pinhole's), `in_common_view`
    decides. (Pose planning asks this of thousands of configurations, one at a time.)"""
    x, y, z = (float(c) for c in np.asarray(point, dtype=float).reshape(3))
    undecided = False
    for camera in cameras:
        if not camera.pinhole:
            undecided = True
            continue
        (a0, a1, a2, a3), (b0, b1, b2, b3), (c0, c1, c2, c3) = camera.P.tolist()
        w = c0 * x + c1 * y + c2 * z + c3
        if w <= MIN_DEPTH_M + EDGE_TOLERANCE:
            if w < MIN_DEPTH_M - EDGE_TOLERANCE:
                return False
            undecided = True
            continue
        u = (a0 * x + a1 * y + a2 * z + a3) / w
        v = (b0 * x + b1 * y + b2 * z + b3) / w
        for value, high in ((u, camera.width - 1 - margin_px), (v, camera.height - 1 - margin_px)):
            if value < margin_px - EDGE_TOLERANCE or value > high + EDGE_TOLERANCE:
                return False
            if value < margin_px + EDGE_TOLERANCE or value > high - EDGE_TOLERANCE:
                undecided = True
    if undecided:
        return bool(in_common_view(cameras, [[x, y, z]], margin_px)[0])
    return True


def points_in_view(
    cameras: Sequence[WiimoteCamera],
    count: int,
    rng: np.random.Generator,
    *,
    depth_m: tuple[float, float] = (0.5, 1.2),
    margin_px: float = 20.0,
    min_cameras: int | None = None,
    max_tries: int = 1000,
) -> NDArray[np.float64]:
    """`count` points (N, 3) in the cameras' frame that at least `min_cameras` cameras (default:
    all) see `margin_px` inside their image: each along the ray of a uniformly drawn pixel of a
    camera (cam0 when all must see it, a random one otherwise) at a depth uniform in `depth_m`."""
    need = len(cameras) if min_cameras is None else min_cameras
    found: list[NDArray[np.float64]] = []
    have = 0
    for _ in range(max_tries):
        reference = cameras[0] if need == len(cameras) else cameras[int(rng.integers(len(cameras)))]
        batch = max(4 * (count - have), 64)
        uv = np.column_stack(
            [
                rng.uniform(margin_px, reference.width - 1 - margin_px, batch),
                rng.uniform(margin_px, reference.height - 1 - margin_px, batch),
            ]
        )
        depth = rng.uniform(*depth_m, batch)
        rays = homogeneous(uv) @ np.linalg.inv(reference.K).T
        X = (rays * depth[:, None] - reference.t) @ reference.R  # camera -> frame
        ok = np.sum([camera.in_view(camera.project(X), margin_px) for camera in cameras], axis=0) >= need
        found.append(X[ok])
        have += int(ok.sum())
        if have >= count:
            return np.concatenate(found)[:count]
    raise VisionError(
        f"could not find {count} points that {need} of the {len(cameras)} cameras see at depths {depth_m} m: "
        "the cameras' fields of view barely overlap there"
    )


def points_in_common_view(
    cameras: Sequence[WiimoteCamera],
    count: int,
    rng: np.random.Generator,
    *,
    depth_m: tuple[float, float] = (0.5, 1.2),
    margin_px: float = 20.0,
    max_tries: int = 1000,
) -> NDArray[np.float64]:
    """`count` points (N, 3) in the cameras' frame that every camera sees `margin_px` inside its
    image, at depths (along cam0's optical axis) uniform in `depth_m` (`points_in_view`)."""
    return points_in_view(cameras, count, rng, depth_m=depth_m, margin_px=margin_px, max_tries=max_tries)


def observe_all(
    cameras: list[WiimoteCamera],
    points: ArrayLike,
    rng: np.random.Generator,
    *,
    sigma_px: float = 0.5,
) -> NDArray[np.float64]:
    """Every camera's noisy integer pixels (C, N, 2) of `points`, one source at a time (no 4-blob
    limit: a calibration or test set is observed one marker position per frame)."""
    return np.stack([camera.observe(points, rng, sigma_px=sigma_px, max_blobs=None) for camera in cameras])
