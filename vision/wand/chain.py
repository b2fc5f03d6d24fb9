"""The first estimate of every camera's pose: camera pairs, chained from the first camera.

Camera 0 defines the frame (R_0 = I, t_0 = 0). The others join one at a time along a maximum
spanning tree of the cameras, an edge's weight being the frames in which both cameras saw both
LEDs (Prim's algorithm from camera 0): each new camera c joins through the placed camera p it
shares most frames with. For that pair:

1. the end assignment and the epipolar geometry (`ends.swap_ransac`), the essential matrix nearest
   it and the pose X_c = R_pc X_p + t_pc with ||t_pc|| = 1 that puts the wand in front of both
   (`relative_pose`), in normalised coordinates of the nominal intrinsics;
2. the scale: the pair's frames triangulated with that unit baseline give wand lengths l_k, and
   s = L / median(l_k) (`scale.wand_scale`), so every pair is metric on its own;
3. the composition: with X_p = R_p X + t_p,

       R_c = R_pc R_p,        t_c = R_pc t_p + s t_pc.

The pair's triangulated wand also tells whether the motion can determine the cameras: the wand's
directions u_k must turn. With the orientation tensor T = mean_k(u_k u_k^T) (its largest
eigenvalue is 1 when every u_k is the same axis, 1/3 for directions spread evenly over the
sphere), a largest eigenvalue above `MAX_ALIGNMENT` (all directions within about 10 degrees of
one axis) is refused: a wand that only translates leaves the end assignment and the intrinsics
undetermined.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from wiithrow.vision.errors import DegenerateMotionError, TooFewFramesError, WandNotSeenError
from wiithrow.vision.geometry import compose
from wiithrow.vision.triangulation import triangulate
from wiithrow.vision.wand.ends import MIN_PAIR_FRAMES, ordered, swap_ransac
from wiithrow.vision.wand.observations import both_ends_seen
from wiithrow.vision.wand.relative_pose import closest_essential, normalised, relative_pose
from wiithrow.vision.wand.scale import check_depths, wand_scale

#: Largest eigenvalue of the wand directions' orientation tensor above which the motion is refused.
MAX_ALIGNMENT = 0.97


@dataclass(frozen=True)
class InitialRig:
    """Every camera's first pose, R (C, 3, 3) and t (C, 3) (x_cam = R X + t, camera 0's frame, metres),
    with the nominal intrinsics K (C, 3, 3); `edges` the (parent, child) order they joined in."""

    K: NDArray[np.float64]
    R: NDArray[np.float64]
    t: NDArray[np.float64]
    edges: tuple[tuple[int, int], ...]

    @property
    def Ps(self) -> NDArray[np.float64]:
        """K [R | t] per camera, (C, 3, 4)."""
        return compose(self.K, self.R, self.t)


def stray_sources(crowded: NDArray[np.int64], frames: int, names: Sequence[str]) -> str:
    """What to say about cameras that saw more than two dots (`crowded` (C,) of `frames` frames)
    in over a tenth of the frames: '' when none did."""
    blinded = [
        f"{name} saw more than two dots in {n} of {frames} frames"
        for name, n in zip(names, crowded)
        if n > 0.1 * frames
    ]
    return "; ".join(blinded) + ": switch off the other IR sources in their view" if blinded else ""


def check_cameras(both: NDArray[np.bool_], names: Sequence[str], crowded: NDArray[np.int64] | None = None) -> None:
    """Raise WandNotSeenError for a camera that saw both ends (C, N) in fewer than
    `MIN_PAIR_FRAMES` frames, saying why when it saw more than two dots (`crowded` (C,) frames)."""
    for c, name in enumerate(names):
        n = int(both[c].sum())
        if n >= MIN_PAIR_FRAMES:
            continue
        stray = stray_sources(crowded[c : c + 1], both.shape[1], [name]) if crowded is not None else ""
        why = stray or "point it at the volume where the wand is waved (or check that its remote is connected)"
        seen = "never saw both LEDs of the wand in one frame" if n == 0 else f"saw both LEDs in only {n} frames"
        raise WandNotSeenError(f"{name} {seen}: {why}")


def spanning_order(both: NDArray[np.bool_], names: Sequence[str]) -> list[tuple[int, int]]:
    """The (placed, new) camera pairs of a maximum spanning tree from camera 0, by the number of
    frames in which both saw both ends (C, N). Raises WandNotSeenError for a camera that shares fewer
    than `MIN_PAIR_FRAMES` such frames with every placed camera."""
    C = both.shape[0]
    shared = both.astype(np.int64) @ both.T.astype(np.int64)
    placed = [0]
    edges: list[tuple[int, int]] = []
    while len(placed) < C:
        best = max(((shared[p, c], p, c) for p in placed for c in range(C) if c not in placed), default=None)
        assert best is not None
        count, p, c = best
        if count < MIN_PAIR_FRAMES:
            raise WandNotSeenError(
                f"{names[c]} saw both LEDs together with another camera in only {count} frames (at least "
                f"{MIN_PAIR_FRAMES} needed): wave the wand where it and its neighbours see it"
            )
        placed.append(c)
        edges.append((p, c))
    return edges


def alignment(directions: NDArray[np.float64]) -> float:
    """The largest eigenvalue of mean(u u^T) over unit directions (M, 3): 1 when all are parallel."""
    u = directions[np.isfinite(directions).all(axis=1)]
    if len(u) == 0:
        return 1.0
    return float(np.linalg.eigvalsh(u.T @ u / len(u))[-1])


def check_motion(directions: NDArray[np.float64]) -> None:
    """Refuse a wand that kept one orientation (see the module docstring)."""
    a = alignment(directions)
    if a > MAX_ALIGNMENT:
        spread = np.degrees(np.arccos(np.sqrt(min(a, 1.0))))
        raise DegenerateMotionError(
            f"the wand kept one orientation (its directions stay within about {spread:.0f} degrees of one "
            "axis): it was only translated, which cannot determine the cameras; turn it in every "
            "direction while you wave it"
        )


def initial_rig(
    pixels: NDArray[np.float64],
    wand_length_m: float,
    K: NDArray[np.float64],
    rng: np.random.Generator,
    names: Sequence[str],
) -> InitialRig:
    """The chained first estimate (see the module docstring) from observations (C, N, 2, 2) and
    nominal intrinsics K (C, 3, 3)."""
    C = pixels.shape[0]
    both = both_ends_seen(pixels)
    edges = spanning_order(both, names)
    R = np.zeros((C, 3, 3))
    t = np.zeros((C, 3))
    R[0] = np.eye(3)
    for p, c in edges:
        frames = np.flatnonzero(both[p] & both[c])
        xp = normalised(pixels[p, frames], K[p])
        xc = normalised(pixels[c, frames], K[c])
        pair = swap_ransac(xp, xc, rng, focal_px=float(K[p, 0, 0]))
        use = pair.decided
        if use.sum() < MIN_PAIR_FRAMES:
            raise TooFewFramesError(
                f"{names[p]} and {names[c]} share only {int(use.sum())} frames in which the wand's ends can be told "
                f"apart (at least {MIN_PAIR_FRAMES}): wave the wand longer, turning it, where both see it"
            )
        xc_ordered = ordered(xc, pair.swap)
        E = closest_essential(pair.F)
        R_pc, t_pc = relative_pose(E, xp[use].reshape(-1, 2), xc_ordered[use].reshape(-1, 2))
        P_p = np.hstack([np.eye(3), np.zeros((3, 1))])
        P_c = np.hstack([R_pc, t_pc[:, None]])
        n = int(use.sum())
        image = np.stack([xp[use].transpose(1, 0, 2).reshape(-1, 2), xc_ordered[use].transpose(1, 0, 2).reshape(-1, 2)])
        X = triangulate(np.stack([P_p, P_c]), image).points
        ends_a, ends_b = X[:n], X[n:]
        s = wand_scale(np.linalg.norm(ends_a - ends_b, axis=1), wand_length_m)
        check_depths(s * np.concatenate([ends_a[:, 2], ends_b[:, 2]]), wand_length_m)
        check_motion((ends_a - ends_b) / np.linalg.norm(ends_a - ends_b, axis=1, keepdims=True))
        R[c] = R_pc @ R[p]
        t[c] = R_pc @ t[p] + s * t_pc
    return InitialRig(K.copy(), R, t, tuple(edges))
