"""Which dot is which end of the wand, in every camera and frame.

The two LEDs look alike, so in frame k camera c reports them in an arbitrary order. What matters is
that the order agrees across cameras within a frame (each frame has its own wand pose, so the order
may change from frame to frame). Two steps, one before any camera is known and one after:

1. A camera pair, no cameras yet (`swap_ransac`). For frame k let s_k = 0 when camera i's (a, b)
   are camera j's (a, b), s_k = 1 when they are (b, a). A RANSAC over frames: draw 4 frames (8
   points), and for each of the 2^4 assignments of their s_k fit F by the eight-point algorithm
   (`relative_pose.eight_point`); score every frame by its better assignment,

       e_k = min over s of ( d(a_i, a_j^s) + d(b_i, b_j^s) ) / 2       (Sampson distances in px),

   with the MSAC cost sum_k min(e_k^2, thr^2). The best model is refitted on its inliers with
   their assignments, three times. Only the true assignment makes every frame consistent with one
   F when the wand turns as it moves (a wand that only translates makes a second, swapped F as
   good: `wiithrow.vision.wand.chain` refuses that motion). A frame whose two assignments are
   both within the threshold (the wand nearly in an epipolar plane) stays undecided here.
2. All cameras, once they are placed (`label_frames`): for each frame every assignment of the
   cameras 1..C-1 relative to camera 0 (2^(C-1) <= 8) is triangulated and the one with the least
   reprojection error wins; assignments within `tie_px` of it are told apart by how close the
   triangulated wand length comes to the true one, which settles the epipolar-plane case of
   two cameras. A frame whose wand length is a gross outlier,

       |l_k - median(l)| > `OUTLIER_MADS` * 1.4826 * MAD(l)        (MAD: median absolute deviation),

   has a wrong dot in some camera (the synchroniser interpolated across a blob that changed slots,
   a reflection): it is not used. A camera that saw one dot has it assigned to the nearer
   projected end, when that is unambiguous.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from wiithrow.vision.errors import TooFewFramesError
from wiithrow.vision.geometry import project
from wiithrow.vision.triangulation import triangulate
from wiithrow.vision.wand.observations import both_ends_seen
from wiithrow.vision.wand.relative_pose import eight_point, sampson_px

#: Frames a camera pair must share (both ends in both cameras) to estimate its geometry.
MIN_PAIR_FRAMES = 20
#: Frames whose wand length lies this many robust standard deviations from the median are dropped.
OUTLIER_MADS = 6.0
#: The 16 assignments of 4 sampled frames: bit f of row j is frame f's swap.
_ASSIGNMENTS = (np.arange(16)[:, None] >> np.arange(4)[None, :]) & 1


@dataclass(frozen=True)
class PairGeometry:
    """The epipolar geometry of a camera pair over their shared frames.

    F: fundamental matrix in the normalised coordinates given; errors_px (K, 2): each frame's
    mean Sampson distance for s = 0 and s = 1; swap (K,): the assignment chosen (0 or 1);
    inliers (K,): the chosen assignment is within the threshold; decided (K,): inlier and the other
    assignment is not.
    """

    F: NDArray[np.float64]
    errors_px: NDArray[np.float64]
    swap: NDArray[np.int64]
    inliers: NDArray[np.bool_]
    decided: NDArray[np.bool_]


def ordered(x: NDArray[np.float64], swap: NDArray[np.int64]) -> NDArray[np.float64]:
    """A camera's ends (K, 2, 2) with the two swapped where `swap` (K,) is 1."""
    out = x.copy()
    flip = swap.astype(bool)
    out[flip] = x[flip][:, ::-1]
    return out


def _frame_errors(
    F: NDArray[np.float64], xi: NDArray[np.float64], xj: NDArray[np.float64], focal_px: float
) -> NDArray[np.float64]:
    """Per model and frame, the mean Sampson error of each assignment: (..., K, 2)."""
    a, b = xi[:, 0], xi[:, 1]
    d_aa = sampson_px(F, a, xj[:, 0], focal_px)
    d_bb = sampson_px(F, b, xj[:, 1], focal_px)
    d_ab = sampson_px(F, a, xj[:, 1], focal_px)
    d_ba = sampson_px(F, b, xj[:, 0], focal_px)
    errors: NDArray[np.float64] = np.stack([(d_aa + d_bb) / 2, (d_ab + d_ba) / 2], axis=-1)
    return errors


def swap_ransac(
    xi: NDArray[np.float64],
    xj: NDArray[np.float64],
    rng: np.random.Generator,
    *,
    focal_px: float,
    threshold_px: float = 2.5,
    samples: int = 100,
    score_frames: int = 300,
) -> PairGeometry:
    """The epipolar geometry of two cameras and the end assignment of every shared frame, from the
    two ends (K, 2, 2) each camera saw in K frames, in normalised coordinates (see the module
    docstring). Raises TooFewFramesError for fewer than `MIN_PAIR_FRAMES` frames."""
    K = xi.shape[0]
    if K < MIN_PAIR_FRAMES:
        raise TooFewFramesError(
            f"only {K} frames in which both cameras saw both LEDs (at least {MIN_PAIR_FRAMES} needed): "
            "wave the wand where both cameras see it"
        )
    scoring = rng.choice(K, size=min(K, score_frames), replace=False)
    picks = np.argsort(rng.random((samples, K)), axis=1)[:, :4]  # (S, 4) distinct frames
    S = samples
    a_i = np.broadcast_to(xi[picks][:, None], (S, 16, 4, 2, 2))
    b_j = xj[picks][:, None].repeat(16, axis=1)  # (S, 16, 4, 2, 2)
    flip = np.broadcast_to(_ASSIGNMENTS[None, :, :].astype(bool), (S, 16, 4))
    b_j[flip] = b_j[flip][:, ::-1]
    F = eight_point(a_i.reshape(S * 16, 8, 2), b_j.reshape(S * 16, 8, 2))
    errors = _frame_errors(F, xi[scoring], xj[scoring], focal_px).min(axis=-1)  # (S*16, scored)
    cost = np.minimum(errors, threshold_px) ** 2
    best = F[int(np.argmin(cost.sum(axis=1)))]
    for _ in range(3):  # refit on the inliers of every frame, with their assignments
        e = _frame_errors(best, xi, xj, focal_px)
        swap = np.argmin(e, axis=1)
        inliers = e[np.arange(K), swap] < threshold_px
        if inliers.sum() < 4:
            break
        best = eight_point(xi[inliers].reshape(-1, 2), ordered(xj, swap)[inliers].reshape(-1, 2))
    e = _frame_errors(best, xi, xj, focal_px)
    swap = np.argmin(e, axis=1).astype(np.int64)
    inliers = e[np.arange(K), swap] < threshold_px
    decided = inliers & (e[np.arange(K), 1 - swap] >= threshold_px)
    return PairGeometry(best, e, swap, inliers, decided)


@dataclass(frozen=True)
class Labels:
    """Every camera's ends put in one order per frame.

    pixels: (C, N, 2, 2) the observations reordered (end 0 of every camera is one LED); usable:
    (N,) the frame's order is known, at least two cameras saw both ends and its length is no
    outlier; reprojection_px: (N,) RMS reprojection error of the chosen order (NaN where not
    usable); length_m: (N,) the triangulated wand length of that order; outliers: frames left out
    for their length.
    """

    pixels: NDArray[np.float64]
    usable: NDArray[np.bool_]
    reprojection_px: NDArray[np.float64]
    length_m: NDArray[np.float64]
    outliers: int


def _reprojection_rms(
    Ps: NDArray[np.float64], image: NDArray[np.float64], points: NDArray[np.float64]
) -> NDArray[np.float64]:
    """RMS over the cameras that saw it of each point's reprojection error: image (C, M, 2)."""
    sq = np.zeros(points.shape[0])
    n = np.zeros(points.shape[0])
    for c in range(Ps.shape[0]):
        r = np.sum((project(Ps[c], points) - image[c]) ** 2, axis=1)
        seen = np.isfinite(r)
        sq[seen] += r[seen]
        n[seen] += 1
    with np.errstate(invalid="ignore", divide="ignore"):
        rms: NDArray[np.float64] = np.sqrt(sq / n)
    return rms


def label_frames(
    Ps: NDArray[np.float64],
    pixels: NDArray[np.float64],
    wand_length_m: float,
    *,
    tie_px: float = 0.5,
    single_gate_px: float = 15.0,
) -> Labels:
    """Put every camera's ends in one order per frame, given the cameras (C, 3, 4) (see the module
    docstring, step 2). `pixels` (C, N, 2, 2) as observed."""
    C, N = pixels.shape[:2]
    both = both_ends_seen(pixels)
    best_score = np.full(N, np.inf)
    best_length = np.full(N, np.nan)
    best_rms = np.full(N, np.nan)
    best_combo = np.zeros(N, dtype=np.int64)
    for combo in range(2 ** (C - 1)):
        flips = np.array([0] + [(combo >> (c - 1)) & 1 for c in range(1, C)], dtype=bool)
        x = np.where(both[..., None, None], pixels, np.nan)
        x[flips] = x[flips][:, :, ::-1]
        image = x.transpose(0, 2, 1, 3).reshape(C, 2 * N, 2)  # end 0 of every frame, then end 1
        X = triangulate(Ps, image).points
        rms = _reprojection_rms(Ps, image, X).reshape(2, N)
        rms = np.sqrt(np.mean(rms**2, axis=0))
        length = np.linalg.norm(X[:N] - X[N:], axis=1)
        # the order's score: its reprojection error, ties broken by the wand length
        score = rms + tie_px * np.minimum(np.abs(length - wand_length_m) / (0.05 * wand_length_m), 1.0)
        better = np.isfinite(score) & (score < best_score)
        best_score[better], best_combo[better] = score[better], combo
        best_rms[better], best_length[better] = rms[better], length[better]
    out = pixels.copy()
    for c in range(1, C):
        flip = ((best_combo >> (c - 1)) & 1).astype(bool) & both[c]
        out[c, flip] = pixels[c, flip][:, ::-1]
    paired = (both.sum(axis=0) >= 2) & np.isfinite(best_rms)
    usable = paired & _typical(best_length)
    _assign_single_dots(Ps, out, usable, single_gate_px)
    return Labels(
        out,
        usable,
        np.where(usable, best_rms, np.nan),
        np.where(usable, best_length, np.nan),
        int((paired & ~usable).sum()),
    )


def _typical(lengths: NDArray[np.float64]) -> NDArray[np.bool_]:
    """Lengths within `OUTLIER_MADS` robust standard deviations of their median (NaN: False)."""
    finite = lengths[np.isfinite(lengths)]
    if finite.size == 0:
        return np.zeros(lengths.shape, dtype=np.bool_)
    median = np.median(finite)
    spread = 1.4826 * np.median(np.abs(finite - median))
    with np.errstate(invalid="ignore"):
        typical: NDArray[np.bool_] = np.abs(lengths - median) <= OUTLIER_MADS * max(spread, 1e-6 * median)
    return typical


def _assign_single_dots(
    Ps: NDArray[np.float64], pixels: NDArray[np.float64], usable: NDArray[np.bool_], gate_px: float
) -> None:
    """Cameras that saw one dot in a usable frame: give it to the nearer projected end when that
    end is within `gate_px` and the other is more than twice as far; drop it otherwise (in place)."""
    C = pixels.shape[0]
    single = np.isfinite(pixels[..., 0]).sum(axis=2) == 1  # (C, N)
    single &= usable[None, :]
    if not single.any():
        return
    both = both_ends_seen(pixels)
    image = np.where(both[..., None, None], pixels, np.nan).transpose(0, 2, 1, 3).reshape(C, -1, 2)
    N = pixels.shape[1]
    X = triangulate(Ps, image).points
    for c in range(C):
        frames = np.flatnonzero(single[c])
        if frames.size == 0:
            continue
        dot = pixels[c, frames, 0]
        d = np.stack(
            [np.linalg.norm(project(Ps[c], X[e * N + frames]) - dot, axis=1) for e in range(2)], axis=1
        )  # (n, 2)
        nearer = np.argmin(np.nan_to_num(d, nan=np.inf), axis=1)
        near = d[np.arange(frames.size), nearer]
        far = d[np.arange(frames.size), 1 - nearer]
        keep = (near < gate_px) & (far > 2 * near)
        pixels[c, frames] = np.nan
        pixels[c, frames[keep], nearer[keep]] = dot[keep]
