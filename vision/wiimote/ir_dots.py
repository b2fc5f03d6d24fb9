"""The IR camera's dot formats inside the input reports, both ways: basic, extended and full.

A dot is a blob the camera tracks in one of four slots: its pixel (x, y) on the 1024x768 grid
(10 bits each), in the extended and full formats its size (0-15), in the full format its bounding
box on the 128x96 sensor (7 bits per value) and its intensity (`docs/wiimote.md`). The encoders
are the remote's side (the simulator and the tests use them); the decoders collect the visible
dots of one report into `IRReportFields`.

Decoded dots follow the project's conventions: pixel coordinates 0..1023 x 0..767, and a missing
dot is simply absent (the driver turns that into NaN). On the wire a missing dot is sent as all
0xFF (x or y = 1023); newer remotes sometimes send (0, 0) for a blob they have not measured yet:
both are missing here. A y beyond the sensor (768..1022) cannot be a real dot and is treated as
missing as well.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field

from wiithrow.vision.wiimote.protocol import ProtocolError

Dot = tuple[int, int]
BBox = tuple[int, int, int, int]

MISSING = 1023


def _present(x: int, y: int) -> bool:
    """A dot is missing when x or y is 1023 (all 0xFF), at (0, 0), or y beyond the sensor."""
    return x != MISSING and y < 768 and not (x == 0 and y == 0)


def _check_dot(slot: int, dot: Dot) -> tuple[int, int]:
    x, y = int(dot[0]), int(dot[1])
    if not (0 <= x <= 1023 and 0 <= y <= 1023):
        raise ProtocolError(f"dot {slot} at ({x}, {y}) does not fit in 10 bits")
    return x, y


def encode_dots_basic(dots: Mapping[int, Dot]) -> bytes:
    """Basic IR, 10 bytes: two 5-byte groups (slots 0-1, 2-3), each
    `[x1 lo, y1 lo, y1hi<<6 | x1hi<<4 | y2hi<<2 | x2hi, x2 lo, y2 lo]`; a missing dot is x = y = 1023."""
    out = bytearray()
    for first in (0, 2):
        x1, y1 = _check_dot(first, dots[first]) if first in dots else (MISSING, MISSING)
        x2, y2 = _check_dot(first + 1, dots[first + 1]) if first + 1 in dots else (MISSING, MISSING)
        hi = ((y1 >> 8) << 6) | ((x1 >> 8) << 4) | ((y2 >> 8) << 2) | (x2 >> 8)
        out += bytes([x1 & 0xFF, y1 & 0xFF, hi, x2 & 0xFF, y2 & 0xFF])
    return bytes(out)


def decode_dots_basic(ir: bytes, first_slot: int = 0) -> dict[int, Dot]:
    """Inverse of `encode_dots_basic` for 10 bytes (4 dots from `first_slot`)."""
    dots: dict[int, Dot] = {}
    for group in range(len(ir) // 5):
        b = ir[5 * group : 5 * group + 5]
        x1 = b[0] | ((b[2] >> 4) & 0x03) << 8
        y1 = b[1] | ((b[2] >> 6) & 0x03) << 8
        x2 = b[3] | (b[2] & 0x03) << 8
        y2 = b[4] | ((b[2] >> 2) & 0x03) << 8
        for k, (x, y) in enumerate(((x1, y1), (x2, y2))):
            if _present(x, y):
                dots[first_slot + 2 * group + k] = (x, y)
    return dots


def encode_dot_extended(dot: Dot | None, size: int = 0) -> bytes:
    """Extended IR, 3 bytes per dot: `[x lo, y lo, yhi<<6 | xhi<<4 | size]`; missing = FF FF FF."""
    if dot is None:
        return b"\xff\xff\xff"
    x, y = _check_dot(-1, dot)
    if not 0 <= int(size) <= 15:
        raise ProtocolError(f"blob size must be 0-15, got {size}")
    return bytes([x & 0xFF, y & 0xFF, ((y >> 8) << 6) | ((x >> 8) << 4) | int(size)])


def _decode_dot_extended(b: bytes) -> tuple[int, int, int]:
    x = b[0] | ((b[2] >> 4) & 0x03) << 8
    y = b[1] | ((b[2] >> 6) & 0x03) << 8
    return x, y, b[2] & 0x0F


def encode_dots_extended(dots: Mapping[int, Dot], sizes: Mapping[int, int] | None = None) -> bytes:
    """Extended IR, 12 bytes: slots 0-3, 3 bytes each."""
    sizes = sizes or {}
    return b"".join(encode_dot_extended(dots.get(s), sizes.get(s, 0)) for s in range(4))


def encode_dot_full(dot: Dot | None, size: int = 0, bbox: BBox = (0, 0, 0, 0), intensity: int = 0) -> bytes:
    """Full IR, 9 bytes per dot: the extended 3, then xmin, ymin, xmax, ymax (7 bits each),
    0x00, intensity; a missing dot is nine 0xFF."""
    if dot is None:
        return b"\xff" * 9
    if any(not 0 <= int(v) <= 127 for v in bbox):
        raise ProtocolError(f"bounding box values are 7 bits (0-127), got {tuple(bbox)}")
    if not 0 <= int(intensity) <= 255:
        raise ProtocolError(f"intensity is one byte, got {intensity}")
    return encode_dot_extended(dot, size) + bytes([int(v) for v in bbox]) + bytes([0, int(intensity)])


def encode_dots_full(
    dots: Mapping[int, Dot],
    sizes: Mapping[int, int] | None = None,
    bboxes: Mapping[int, BBox] | None = None,
    intensities: Mapping[int, int] | None = None,
    slots: Iterable[int] = (0, 1),
) -> bytes:
    """Full IR, 18 bytes for two slots (0-1 in report 0x3E, 2-3 in 0x3F)."""
    sizes, bboxes, intensities = sizes or {}, bboxes or {}, intensities or {}
    return b"".join(
        encode_dot_full(dots.get(s), sizes.get(s, 0), bboxes.get(s, (0, 0, 0, 0)), intensities.get(s, 0)) for s in slots
    )


@dataclass
class IRReportFields:
    """What a decoder collects for the visible dots of one report (slot -> value)."""

    dots: dict[int, Dot] = field(default_factory=dict)
    sizes: dict[int, int] = field(default_factory=dict)
    bboxes: dict[int, BBox] = field(default_factory=dict)
    intensities: dict[int, int] = field(default_factory=dict)


def decode_dots_extended_into(ir: bytes, first_slot: int, out: IRReportFields) -> None:
    # The same arithmetic as `_decode_dot_extended` and `_present`, inlined: this runs for every
    # dot of every report (400 per second per remote).
    dots, sizes = out.dots, out.sizes
    for k in range(len(ir) // 3):
        lo_x, lo_y, hi = ir[3 * k], ir[3 * k + 1], ir[3 * k + 2]
        x = lo_x | (hi & 0x30) << 4
        y = lo_y | (hi & 0xC0) << 2
        if x != MISSING and y < 768 and (x or y):
            dots[first_slot + k] = (x, y)
            sizes[first_slot + k] = hi & 0x0F


def decode_dots_full_into(ir: bytes, first_slot: int, out: IRReportFields) -> None:
    for k in range(len(ir) // 9):
        b = ir[9 * k : 9 * k + 9]
        x, y, size = _decode_dot_extended(b[:3])
        if _present(x, y):
            s = first_slot + k
            out.dots[s] = (x, y)
            out.sizes[s] = size
            out.bboxes[s] = (b[3] & 0x7F, b[4] & 0x7F, b[5] & 0x7F, b[6] & 0x7F)
            out.intensities[s] = b[8]
