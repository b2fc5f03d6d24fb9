"""What the simulated remote's data reports carry: the IR camera's view at time t, and its bytes.

`SimulatedCamera` is the remote's IR camera: a `WiimoteCamera` looking at the world's IR sources,
`sources(t)` giving their positions (M, 3) in the camera's mount frame at time t (an array, or rows
of plain floats as a tuple of (x, y, z), taken as they are);
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
from functools import lru_cache

import numpy as np
from numpy.typing import NDArray

from wiithrow.vision.camera import WiimoteCamera
from wiithrow.vision.wiimote.input_reports import encode_ir_report
from wiithrow.vision.wiimote.ir_dots import MISSING, BBox, Dot
from wiithrow.vision.wiimote.protocol import (
    IN_BUTTONS_ACCEL_IR10_EXT6,
    IN_BUTTONS_ACCEL_IR12,
    IN_BUTTONS_IR10_EXT9,
    IN_INTERLEAVED_A,
    IN_INTERLEAVED_B,
    INPUT_LENGTHS,
    MAX_REPORT_LENGTH,
)

#: IR sources as rows of plain floats (x, y, z): what a `sources` callable may give instead of an
#: (M, 3) array (the MuJoCo lab's LEDs), used as they are.
SourceRows = tuple[tuple[float, float, float], ...]
#: `sources(t)`: the IR sources at time t in the camera's mount frame, (M, 3) or `SourceRows`.
Sources = Callable[[float], "NDArray[np.float64] | SourceRows"]

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
        sources: Sources,
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
        seen_from = self.sources(t)
        pts: SourceRows | list[list[float]] = (
            seen_from if isinstance(seen_from, tuple) else np.asarray(seen_from, dtype=float).reshape(-1, 3).tolist()
        )
        frame = CameraFrame()
        if not pts or blind:
            self.reset()
            return frame
        pixels, sizes = self.camera.observe_few(
            pts, self.rng, sigma_px=self.sigma_px, dropout=self.dot_dropout, max_blobs=None
        )
        # seen, and neither x = 1023 nor (0, 0): those read as "missing" on the wire
        visible = [p is not None and p[0] != MISSING and (p[0] != 0 or p[1] != 0) for p in pixels]
        n = len(visible)
        slot_sources = self._slot_sources
        free = False  # a slot is free (after the lost blobs let theirs go)
        for s, tracked_src in enumerate(slot_sources):
            if tracked_src is not None and (tracked_src >= n or not visible[tracked_src]):
                slot_sources[s] = tracked_src = None
            if tracked_src is None:
                free = True
        if free:  # the sources seen and not tracked take the lowest free slots, in source order
            for src, seen in enumerate(visible):
                if not seen or src in slot_sources:
                    continue
                if None not in slot_sources:
                    break
                s = slot_sources.index(None)
                slot_sources[s] = src
                frame.new.add(s)
        frame_slots, frame_sizes = frame.slots, frame.sizes
        for s, slot_src in enumerate(slot_sources):
            if slot_src is not None:
                x, y = pixels[slot_src]  # type: ignore[misc]  # visible, so not None
                frame_slots[s] = (slot_src, x, y)
                frame_sizes[s] = min(max(sizes[slot_src], 0), 15)
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


@dataclass
class FrameFields:
    """What a data report carries of a frame: slot -> dot, size, bounding box, intensity (the
    arguments of `input_reports.encode_ir_report`)."""

    dots: dict[int, Dot] = field(default_factory=dict)
    sizes: dict[int, int] = field(default_factory=dict)
    bboxes: dict[int, BBox] = field(default_factory=dict)
    intensities: dict[int, int] = field(default_factory=dict)


def frame_fields(
    report_id: int, frame: CameraFrame, *, zero_missing: bool = False, zero_first: bool = False
) -> FrameFields:
    """The dots (and sizes; bounding boxes and intensity 40 + 24 size, at most 255, in the full
    format only) that report `report_id` carries of `frame`. `zero_missing`: empty slots are sent as
    (0, 0); `zero_first`: a new blob shows at (0, 0)."""
    out = FrameFields()
    full = report_id in (IN_INTERLEAVED_A, IN_INTERLEAVED_B)
    for s in range(SLOTS):
        if s in frame.slots:
            _, x, y = frame.slots[s]
            size = frame.sizes[s]
            if zero_first and s in frame.new:
                out.dots[s], out.sizes[s] = (0, 0), 0
                continue
            out.dots[s], out.sizes[s] = (x, y), size
            if full:
                out.bboxes[s] = blob_bbox(x, y, size)
                out.intensities[s] = min(255, 40 + 24 * size)
        elif zero_missing:
            out.dots[s], out.sizes[s] = (0, 0), 0
    return out


def encode_frame(
    report_id: int,
    frame: CameraFrame,
    *,
    buttons: int,
    accel: tuple[int, int, int],
    zero_missing: bool = False,
    zero_first: bool = False,
) -> bytes:
    """The data report `report_id` carrying `frame` (`frame_fields`): the bytes of
    `input_reports.encode_ir_report`, packed here without its general checks and joins (a
    simulated remote sends 100 of them a second; `test_fast_encoding_equals_the_encoder`).
    The extended report (0x33) without faults is packed straight from the frame's slots, with
    no `FrameFields` in between (the MuJoCo world's remotes send only these)."""
    if report_id == IN_BUTTONS_ACCEL_IR12 and not (zero_missing or zero_first):
        packed = _pack_extended(frame, int(buttons), accel)
        if packed is not None:
            return packed
    f = frame_fields(report_id, frame, zero_missing=zero_missing, zero_first=zero_first)
    return pack_ir_report(report_id, f, buttons=buttons, accel=accel)


def _pack_extended(frame: CameraFrame, buttons: int, accel: tuple[int, int, int]) -> bytes | None:
    """Report 0x33 of `frame` (`pack_ir_report`'s extended layout: per slot x lo, y lo,
    yhi<<6 | xhi<<4 | size; 0xFF x 3 for an empty slot), or None when a value is out of its
    bits (the general path then lets the encoder say what is wrong)."""
    out = bytearray(_head(IN_BUTTONS_ACCEL_IR12, buttons, accel))
    slots, sizes = frame.slots, frame.sizes
    for s in range(SLOTS):
        seen = slots.get(s)
        if seen is None:
            out += _MISSING_3
            continue
        _, x, y = seen
        size = sizes.get(s, 0)
        if not (0 <= x <= 1023 and 0 <= y <= 1023 and 0 <= size <= 15):
            return None
        out.append(x & 0xFF)
        out.append(y & 0xFF)
        out.append((y >> 8) << 6 | (x >> 8) << 4 | size)
    return bytes(out)


#: Report id -> (bytes before the IR bytes: id, buttons, accelerometer; zero bytes after them).
_LAYOUT = {
    IN_BUTTONS_ACCEL_IR12: (6, 0),
    IN_BUTTONS_IR10_EXT9: (3, 9),
    IN_BUTTONS_ACCEL_IR10_EXT6: (6, 6),
    IN_INTERLEAVED_A: (4, 0),
    IN_INTERLEAVED_B: (4, 0),
}
_MISSING_3 = b"\xff" * 3
_MISSING_9 = b"\xff" * 9
_ZEROS = {n: bytes(n) for _, n in _LAYOUT.values()}


@lru_cache(maxsize=256)
def _head(report_id: int, buttons: int, accel: tuple[int, int, int]) -> bytes:
    """The report's bytes before its IR bytes (id, buttons, accelerometer), from the encoder
    itself: they change only with the buttons."""
    return encode_ir_report(report_id, {}, buttons=buttons, accel=accel)[: _LAYOUT[report_id][0]]


def _in_range(dots: dict[int, Dot], sizes: dict[int, int]) -> bool:
    """Every dot within 10 bits and every size within 0-15 (what the encoder would accept)."""
    for x, y in dots.values():
        if not (0 <= x <= 1023 and 0 <= y <= 1023):
            return False
    return not sizes or (min(sizes.values()) >= 0 and max(sizes.values()) <= 15)


def _extended_dot(dot: tuple[int, int], size: int) -> tuple[int, int, int]:
    """A dot's 3 bytes in the extended layout (also the first 3 of the full one): x and y's low
    bytes, then y's and x's high bits over the 4-bit size."""
    x, y = dot
    return x & 0xFF, y & 0xFF, (y >> 8) << 6 | (x >> 8) << 4 | size


def pack_ir_report(report_id: int, f: FrameFields, *, buttons: int, accel: tuple[int, int, int]) -> bytes:
    """`encode_ir_report(report_id, f.dots, sizes=..., bboxes=..., intensities=..., ...)`, the same
    bytes (the dot layouts of `ir_dots`: extended `[x lo, y lo, yhi<<6 | xhi<<4 | size]`, basic
    pairs `[x1 lo, y1 lo, y1hi<<6 | x1hi<<4 | y2hi<<2 | x2hi, x2 lo, y2 lo]`, full the extended 3 then
    the box, 0, intensity; missing = 0xFF). A value out of its bits goes to the encoder, which
    says what is wrong (`ProtocolError`)."""
    layout = _LAYOUT.get(report_id)
    dots, sizes = f.dots, f.sizes
    if layout is None or not _in_range(dots, sizes):
        return encode_ir_report(
            report_id, dots, sizes=sizes, bboxes=f.bboxes, intensities=f.intensities, buttons=buttons, accel=accel
        )
    out = bytearray(_head(report_id, int(buttons), accel))
    if report_id == IN_BUTTONS_ACCEL_IR12:
        for s in range(SLOTS):
            dot = dots.get(s)
            if dot is None:
                out += _MISSING_3
            else:
                out.extend(_extended_dot(dot, sizes.get(s, 0)))
    elif report_id in (IN_INTERLEAVED_A, IN_INTERLEAVED_B):
        for s in (0, 1) if report_id == IN_INTERLEAVED_A else (2, 3):
            dot = dots.get(s)
            if dot is None:
                out += _MISSING_9
            else:
                out.extend(_extended_dot(dot, sizes.get(s, 0)))
                out.extend(f.bboxes.get(s, (0, 0, 0, 0)))
                out.extend((0, f.intensities.get(s, 0)))
    else:  # basic: two groups of two dots
        for first in (0, 2):
            x1, y1 = dots.get(first, (MISSING, MISSING))
            x2, y2 = dots.get(first + 1, (MISSING, MISSING))
            hi = (y1 >> 8) << 6 | (x1 >> 8) << 4 | (y2 >> 8) << 2 | x2 >> 8
            out.extend((x1 & 0xFF, y1 & 0xFF, hi, x2 & 0xFF, y2 & 0xFF))
    out += _ZEROS[layout[1]]
    return bytes(out)


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
