"""What a wand calibration is made from: each camera's two dots of the wand, frame by frame.

`WandObservations` holds, for N frames at times t (s) and C >= 2 cameras, the pixels of the wand's
two LEDs, `pixels[c, k, e] = (u, v)` for end e in {0 (a), 1 (b)}, NaN where camera c did not see it.
The two LEDs look alike to a Wiimote, so a and b are only the order in which the camera reported
the dots: which dot is which end is not known and may differ between cameras and between frames
(`wiithrow.vision.wand.ends` works it out). A camera that saw one dot has it in a, b NaN.

`from_dots` turns synchronised frames of the remotes' dot slots (what `wiithrow.vision.sync`
emits: (C, K, 2) per frame, NaN for empty slots) into observations: a camera with exactly two dots
gives both ends, one dot gives one end, three or four (another IR source in view) give nothing,
since which two are the wand is not known; `crowded` counts those frames per camera, so that a
camera that never saw the wand can be told why.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike, NDArray

from wiithrow.vision.camera import IMAGE_HEIGHT, IMAGE_WIDTH
from wiithrow.vision.errors import CalibrationError


@dataclass(frozen=True)
class WandObservations:
    """The wand's dots in C >= 2 cameras over N frames (see the module docstring).

    t: (N,) frame times (s), non-decreasing; pixels: (C, N, 2, 2) camera, frame, end, (u, v);
    crowded: (C,) frames in which a camera saw more than two dots (unknown for a CSV: zeros).
    """

    t: NDArray[np.float64]
    pixels: NDArray[np.float64]
    image_size: tuple[int, int] = (IMAGE_WIDTH, IMAGE_HEIGHT)
    crowded: NDArray[np.int64] = field(default_factory=lambda: np.zeros(0, dtype=np.int64))

    def __post_init__(self) -> None:
        t = np.asarray(self.t, dtype=float).reshape(-1)
        x = np.asarray(self.pixels, dtype=float)
        if x.ndim != 4 or x.shape[2:] != (2, 2) or x.shape[1] != t.shape[0]:
            raise CalibrationError(
                f"wand pixels must have shape (cameras, {t.shape[0]} frames, 2 ends, 2), got {x.shape}"
            )
        if x.shape[0] < 2:
            raise CalibrationError(f"a wand calibration needs at least 2 cameras, got {x.shape[0]}")
        if not np.isfinite(t).all() or (np.diff(t) < 0).any():
            raise CalibrationError("wand frame times must be finite and in order")
        if np.isinf(x).any():
            raise CalibrationError("wand pixels contain inf: use NaN where a camera did not see an LED")
        partial = np.isnan(x).any(axis=3) & ~np.isnan(x).all(axis=3)
        if partial.any():
            raise CalibrationError("a wand pixel has one coordinate NaN and the other not: give both or neither")
        object.__setattr__(self, "t", t)
        object.__setattr__(self, "pixels", x)
        crowded = np.asarray(self.crowded, dtype=np.int64).reshape(-1)
        object.__setattr__(self, "crowded", crowded if crowded.size else np.zeros(x.shape[0], dtype=np.int64))

    @property
    def cameras(self) -> int:
        return int(self.pixels.shape[0])

    @property
    def frames(self) -> int:
        return int(self.pixels.shape[1])

    @property
    def seen(self) -> NDArray[np.bool_]:
        """(C, N, 2): camera c saw end e in frame k."""
        seen: NDArray[np.bool_] = np.isfinite(self.pixels[..., 0])
        return seen

    @property
    def both(self) -> NDArray[np.bool_]:
        """(C, N): camera c saw both ends in frame k."""
        return both_ends_seen(self.pixels)

    def subset(self, frames: ArrayLike) -> WandObservations:
        """The observations of some frames (indices or a boolean mask over the N frames)."""
        index = np.asarray(frames)
        return WandObservations(self.t[index], self.pixels[:, index], self.image_size, self.crowded)

    def duration_s(self) -> float:
        return float(self.t[-1] - self.t[0]) if self.frames else 0.0


def both_ends_seen(pixels: NDArray[np.float64]) -> NDArray[np.bool_]:
    """(C, N): which cameras saw both ends in which frames, of pixels (C, N, 2, 2)."""
    return np.asarray(np.isfinite(pixels[..., 0]).all(axis=2), dtype=np.bool_)


def from_dots(times: ArrayLike, dots: Sequence[ArrayLike] | NDArray[np.float64]) -> WandObservations:
    """Observations from synchronised dot frames: `dots[k]` (C, K, 2) at `times[k]` (see the module
    docstring: two dots give both ends, one dot gives end a, more give nothing)."""
    t = np.asarray(times, dtype=float).reshape(-1)
    D = np.asarray(dots, dtype=float)
    if D.ndim != 4 or D.shape[0] != t.shape[0] or D.shape[3] != 2:
        raise CalibrationError(f"dot frames must have shape ({t.shape[0]}, cameras, slots, 2), got {D.shape}")
    N, C = D.shape[:2]
    pixels = np.full((C, N, 2, 2), np.nan)
    visible = np.isfinite(D).all(axis=3)  # (N, C, K)
    count = visible.sum(axis=2)
    order = np.argsort(~visible, axis=2, kind="stable")  # visible slots first, in slot order
    first = np.take_along_axis(D, order[..., None], axis=2)  # (N, C, K, 2)
    for n_dots, ends in ((1, 1), (2, 2)):
        k, c = np.nonzero(count == n_dots)
        pixels[c, k, :ends] = first[k, c, :ends]
    return WandObservations(t, pixels, crowded=(count > 2).sum(axis=0))
