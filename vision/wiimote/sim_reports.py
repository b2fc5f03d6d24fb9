"""What the simulated remote's data reports carry: the IR camera's view at time t, and its bytes.

`SimulatedCamera` is the remote's IR camera: a `WiimoteCamera` looking at the world's IR sources,
`sources(t)` giving their positions (M, 3) in the camera's mount frame at time t;
`WiimoteCamera.observe` adds pixel noise (`sigma_px`) and rounds, `WiimoteCamera.blob_sizes` gives
the sizes. Like the real camera's tracker, a blob keeps its slot while it stays visible and a new
blob takes the lowest free slot; at most four. A dot at x = 1023 or at (0, 0) cannot be told from
"missing" on the wire, so the simulated camera does not report one, and a blind sensitivity
(`RemoteMemory.blind`) sees nothing.

`encode_frame` writes a camera frame as a data report; the full format's bounding box (7 bits per
value, on the 128x96 sensor) and intensity are derived from the blob size, and two faults of real
remotes can be asked for: (0, 0) for the missing slots, and (0, 0) in a new blob's first report.
`garbage_report` makes a report no parser may accept (the garbage fault).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike

from wiithrow.vision.camera import WiimoteCamera
from wiithrow.vision.wiimote.input_reports import encode_ir_report
from wiithrow.vision.wiimote.ir_dots import MISSING, BBox, Dot
from wiithrow.vision.wiimote.protocol import INPUT_LENGTHS, MAX_REPORT_LENGTH

SLOTS = 4


@dataclass
class CameraFrame:
    """One frame of the simulated camera: slot -> (source index, x, y) and slot -> blob size of the
    blobs it tracks, and the slots whose blob appeared in this frame."""

    slots: dict[int, tuple[int, int, int]] = field(default_factory=dict)
    sizes: dict[int, int] = field(default_factory=dict)
    new: set[int] = field(default_factory=set)


class SimulatedCamera:
    """The remote's IR camera: which sources it sees at time t, tracked into slots (see the module
    docstring). Noise and drop-outs are drawn from `rng`."""

    def __init__(
        self,
        camera: WiimoteCamera,
        sources: Callable[[float], ArrayLike],
        rng: np.random.Generator,
        *,
        sigma_px: float = 0.5,
        dot_dropout: float = 0.0,
    ) -> None:
        self.camera = camera
        self.sources = sources
        self.rng = rng
        self.sigma_px = float(sigma_px)
        self.dot_dropout = float(dot_dropout)
        self._slot_sources: list[int | None] = [None] * SLOTS

    def reset(self) -> None:
        """Forget the tracked blobs (a new stream starts)."""
        self._slot_sources = [None] * SLOTS

    def observe(self, t: float, *, blind: bool = False) -> CameraFrame:
        """One camera frame at time t: track blobs into slots (a blob keeps its slot, a new blob
        takes the lowest free one)."""
        pts = np.asarray(self.sources(t), dtype=float).reshape(-1, 3)
        frame = CameraFrame()
        if pts.shape[0] == 0 or blind:
            self.reset()
            return frame
        uv = self.camera.observe(pts, self.rng, sigma_px=self.sigma_px, dropout=self.dot_dropout, max_blobs=None)
        sizes = self.camera.blob_sizes(pts)
        visible = np.isfinite(uv).all(axis=1)
        with np.errstate(invalid="ignore"):
            visible &= uv[:, 0] != MISSING  # x = 1023 reads as "missing" on the wire
            visible &= ~((uv[:, 0] == 0) & (uv[:, 1] == 0))  # so does (0, 0)
        for s, tracked_src in enumerate(self._slot_sources):
            if tracked_src is not None and (tracked_src >= len(visible) or not visible[tracked_src]):
                self._slot_sources[s] = None
        tracked = {src for src in self._slot_sources if src is not None}
        for seen in np.flatnonzero(visible):
            src = int(seen)
            if src in tracked:
                continue
            if None not in self._slot_sources:
                break
            s = self._slot_sources.index(None)
            self._slot_sources[s] = src
            frame.new.add(s)
        for s, slot_src in enumerate(self._slot_sources):
            if slot_src is not None:
                frame.slots[s] = (slot_src, int(uv[slot_src, 0]), int(uv[slot_src, 1]))
                frame.sizes[s] = _clamp(int(sizes[slot_src]), 15)
        return frame


def blob_bbox(x: int, y: int, size: int) -> BBox:
    """A blob's bounding box on the 128x96 sensor, from its centre (x, y) on the 1024x768 grid and
    its size: the centre / 8, +- max(0.5, size / 2), clipped to the sensor."""
    cx, cy, r = x / 8.0, y / 8.0, max(0.5, size / 2.0)
    return (
        _clamp(math.floor(cx - r), 127),
        _clamp(math.floor(cy - r), 95),
        _clamp(math.ceil(cx + r), 127),
        _clamp(math.ceil(cy + r), 95),
    )


def _clamp(value: int, high: int) -> int:
    """`value` within 0..high (plain integers: np.clip costs microseconds on a scalar, per dot per frame)."""
    return min(max(int(value), 0), high)


def encode_frame(
    report_id: int,
    frame: CameraFrame,
    *,
    buttons: int,
    accel: tuple[int, int, int],
    zero_missing: bool = False,
    zero_first: bool = False,
) -> bytes:
    """The data report `report_id` carrying `frame` (intensity 40 + 24 size, at most 255).
    `zero_missing`: empty slots are sent as (0, 0); `zero_first`: a new blob shows at (0, 0)."""
    dots: dict[int, Dot] = {}
    sizes: dict[int, int] = {}
    bboxes: dict[int, BBox] = {}
    intensities: dict[int, int] = {}
    for s in range(SLOTS):
        if s in frame.slots:
            _, x, y = frame.slots[s]
            size = frame.sizes[s]
            if zero_first and s in frame.new:
                dots[s], sizes[s] = (0, 0), 0
                continue
            dots[s], sizes[s] = (x, y), size
            bboxes[s] = blob_bbox(x, y, size)
            intensities[s] = int(min(255, 40 + 24 * size))
        elif zero_missing:
            dots[s], sizes[s] = (0, 0), 0
    return encode_ir_report(
        report_id, dots, sizes=sizes, bboxes=bboxes, intensities=intensities, buttons=buttons, accel=accel
    )


def garbage_report(real: bytes, rng: np.random.Generator) -> bytes:
    """A report no parser may accept: `real` truncated, an unknown id with random bytes, or a known
    id with a wrong length."""
    kind = int(rng.integers(0, 3))
    if kind == 0:  # truncated real report
        return real[: int(rng.integers(1, len(real)))]
    if kind == 1:  # unknown id, random bytes
        unknown = [i for i in range(256) if i not in INPUT_LENGTHS]
        rid = unknown[int(rng.integers(0, len(unknown)))]
        n = int(rng.integers(1, 23))
        return bytes([rid]) + rng.integers(0, 256, size=n - 1, dtype=np.uint8).tobytes()
    ids = sorted(INPUT_LENGTHS)  # known id, wrong length
    rid = ids[int(rng.integers(0, len(ids)))]
    lengths = [n for n in range(1, MAX_REPORT_LENGTH) if n != INPUT_LENGTHS[rid]]
    n = lengths[int(rng.integers(0, len(lengths)))]
    return bytes([rid]) + rng.integers(0, 256, size=n - 1, dtype=np.uint8).tobytes()
