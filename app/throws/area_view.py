"""Whether the calibrated rig sees a training area: every training label is the rig's measurement
of a landing marker, so before a run starts (the session's Start training, `wiithrow train`) the
area where its balls will come down must lie in the common view of the rig's cameras.

Owns `area_not_seen` (one line naming what is not seen and what to change, or None;
`require_area_in_view` raises it), the points it checks (`area_view_points`) and the cameras of a
calibration (`calibrated_cameras`).

What is checked: the area of the throw plane (link1 x from the joint-1 axis, z height) with
`AREA_VIEW_MARGIN_M` around it (x from x_min - margin to x_max + margin, y from -margin to +margin
across the plane), at its heights (z_min and z_max: a landing is where the ball meets a target's
surface); its corners and points along its edges (`EDGE_POINTS` each) must be seen by every camera
`VIEW_MARGIN_PX` inside its image, in front of it (`wiithrow.vision.rig.in_common_view`). The
common view is convex (for a pinhole camera each of its bounds is a plane through the camera's
centre), so a box whose corners are seen is seen whole; the edges are sampled all the same, and
name the side that is lost when a corner is not. The cameras are the calibration's (each P
decomposed into K [R | t], `wiithrow.vision.geometry.decompose`): where the rig looks, whatever the
settings say of its mount.

Azimuths: the rig sits on link1 and turns with joint 1, and the throw plane is y = 0 of link1 at
every azimuth, so the area lies at the same place in the rig's view whatever azimuth a run throws
at: one check in link1 holds for all of them.

Why the margin: a training throw is the simulated operator's solution on the arm's model, and a
lab's arm lands it off by what the model does not know (the lab Panda of the project's issues:
throws up to 85 mm from their targets, one landing 34 mm short of the area's near edge that the
rig did not see); 10 cm keeps such a landing measurable. The corner is named in words ("near left
at z = 0.0 m": near is the area's edge closest to joint 1, left the +y side, as seen from behind
the rig) with the cameras that do not see it and where it falls for each (below, above, left of,
right of its image, or behind it); what to change follows from that (pitch the rig down for a point
below the images, move the area, recalibrate a rig that was moved).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from wiithrow.app.errors import AppError
from wiithrow.throwing import Area
from wiithrow.vision.camera import WiimoteCamera
from wiithrow.vision.errors import VisionError
from wiithrow.vision.geometry import decompose
from wiithrow.vision.rig import in_common_view

#: How far (m) around the training area a landing must still be seen (module docstring).
AREA_VIEW_MARGIN_M = 0.10
#: How far (px) inside each camera's image a landing marker must project: the rig's own margin for
#: a marker it tracks (`in_common_view`'s default, the rig coverage's and the pose planning's).
VIEW_MARGIN_PX = 20.0
#: Points checked along each edge of the area's outline at a height, its two corners included.
EDGE_POINTS = 5


@dataclass(frozen=True)
class ViewPoint:
    """A point of the checked outline: its `name` in words and its position in link1 (m)."""

    name: str
    position: tuple[float, float, float]


def area_view_points(area: Area, margin_m: float = AREA_VIEW_MARGIN_M) -> list[ViewPoint]:
    """The corners of `area` widened by `margin_m` (in x and across the plane in y) at its two
    heights, then points along its edges; named ("near left at z = 0.0 m", "far edge at z = 0.4 m")."""
    (x0, x1), (z0, z1) = sorted(area.x), sorted(area.z)
    near, far, left, right = x0 - margin_m, x1 + margin_m, margin_m, -margin_m
    corners: list[ViewPoint] = []
    edges: list[ViewPoint] = []
    for z in dict.fromkeys((z0, z1)):
        at = f"at z = {z:.1f} m"
        for xname, x in (("near", near), ("far", far)):
            for yname, y in (("left", left), ("right", right)):
                corners.append(ViewPoint(f"{xname} {yname} {at}", (x, y, z)))
        inner = np.linspace(0.0, 1.0, EDGE_POINTS)[1:-1]
        for name, a, b in (
            ("near edge", (near, left), (near, right)),
            ("far edge", (far, left), (far, right)),
            ("left edge", (near, left), (far, left)),
            ("right edge", (near, right), (far, right)),
        ):
            for s in inner:
                x, y = (1 - s) * np.asarray(a) + s * np.asarray(b)
                edges.append(ViewPoint(f"{name} {at}", (float(x), float(y), z)))
    return corners + edges


def calibrated_cameras(Ps: ArrayLike, names: Sequence[str] = ()) -> list[WiimoteCamera]:
    """The cameras of a calibration's projection matrices (C, 3, 4), each P = K [R | t]
    decomposed; named as `names` says (else cam0, cam1, ...). VisionError for a P that is no camera."""
    cameras = []
    for k, P in enumerate(np.asarray(Ps, dtype=float).reshape(-1, 3, 4)):
        d = decompose(P)
        name = names[k] if k < len(names) else f"cam{k}"
        try:
            cameras.append(WiimoteCamera(d.K, d.R, d.t, name=name))
        except ValueError as exc:  # a rotation that is not one: no camera
            raise VisionError(f"the calibration's camera {name} is no camera: {exc}") from None
    return cameras


def area_not_seen(
    area: Area,
    cameras: Sequence[WiimoteCamera],
    *,
    margin_m: float = AREA_VIEW_MARGIN_M,
    margin_px: float = VIEW_MARGIN_PX,
) -> str | None:
    """One line saying which point of `area` (with `margin_m` around it) is not in the common view
    of `cameras` (`margin_px` inside each image), by which camera and where it falls, and what to
    change; None when the rig sees it all (module docstring)."""
    points = area_view_points(area, margin_m)
    seen = in_common_view(cameras, [p.position for p in points], margin_px)
    if seen.all():
        return None
    first = points[int(np.argmin(seen))]  # corners come first: a lost corner is named before an edge
    lost = [n for n, ok in zip(points, seen) if not ok]
    where = [f"{c.name} {side}" for c in cameras if (side := _off_image(c, first.position, margin_px))]
    x, y, _ = first.position
    remedy = _remedy(cameras, first.position, margin_px)
    (ax0, ax1), (az0, az1) = area.x, area.z
    more = f" ({len(lost) - 1} more points of its outline are not seen either)" if len(lost) > 1 else ""
    return (
        f"the rig does not see the training area's {first.name} (x {x:.2f}, y {y:+.2f} m in link1: the area x "
        f"{ax0:.2f}-{ax1:.2f} m, z {az0:.2f}-{az1:.2f} m with {100 * margin_m:.0f} cm around it, where landings "
        f"must be measured): {', '.join(where)}{more}; {remedy}, move the area, or recalibrate if the rig was moved"
    )


def require_area_in_view(area: Area, Ps: ArrayLike | None, names: Sequence[str] = ()) -> None:
    """AppError (`area_not_seen`'s line) unless the rig calibrated with `Ps` (link1) sees `area`
    with its margin; AppError too when the rig has no calibration or one that is no camera."""
    if Ps is None:
        raise AppError("the rig is not calibrated: calibrate it before training (its landings are measured by it)")
    try:
        cameras = calibrated_cameras(Ps, names)
    except VisionError as exc:
        raise AppError(f"the rig's calibration cannot be checked against the training area: {exc}") from None
    why = area_not_seen(area, cameras)
    if why is not None:
        raise AppError(why)


def _off_image(camera: WiimoteCamera, point: tuple[float, float, float], margin_px: float) -> str:
    """Where `point` falls for `camera` when it does not see it ("below its image", ...), else ""."""
    uv = camera.project(np.asarray(point, dtype=float))[0]
    if not np.isfinite(uv).all():
        return "has it behind it"
    u, v = float(uv[0]), float(uv[1])
    sides = []
    if v > camera.height - 1 - margin_px:
        sides.append(f"below its image ({v - (camera.height - 1 - margin_px):.0f} px)")
    if v < margin_px:
        sides.append(f"above its image ({margin_px - v:.0f} px)")
    if u < margin_px:
        sides.append(f"left of its image ({margin_px - u:.0f} px)")
    if u > camera.width - 1 - margin_px:
        sides.append(f"right of its image ({u - (camera.width - 1 - margin_px):.0f} px)")
    return f"sees it {' and '.join(sides)}" if sides else ""


def _remedy(cameras: Sequence[WiimoteCamera], point: tuple[float, float, float], margin_px: float) -> str:
    """What to change for `point` to be seen: the rig's pitch for a point below or above the images,
    its turn for one beside them."""
    uv: NDArray[np.float64] = np.array([c.project(np.asarray(point, dtype=float))[0] for c in cameras])
    if not np.isfinite(uv).all():
        return "bring the area in front of the rig"
    heights = np.array([c.height for c in cameras])
    widths = np.array([c.width for c in cameras])
    if (uv[:, 1] > heights - 1 - margin_px).any():
        return "pitch the rig down"
    if (uv[:, 1] < margin_px).any():
        return "pitch the rig up"
    if (uv[:, 0] < margin_px).any() or (uv[:, 0] > widths - 1 - margin_px).any():
        return "turn the rig towards it"
    return "move the rig"
