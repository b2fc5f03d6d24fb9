"""The input reports (remote -> host): their typed form, `parse`, and the encoders of the remote's side.

`parse(report)` decodes one input report into a `StatusReport` (0x20), `ReadReply` (0x21),
`Ack` (0x22), `IRReport` (0x33, 0x36, 0x37, 0x3E, 0x3F) or `DataReport` (the other data reports),
or raises `ProtocolError` (a `VisionError`, hence a `ValueError`) naming the report id and the
expected and actual length; nothing else ever escapes it. On reads, a report padded to 22 bytes
(what Windows' HID stack returns for the remote's shorter reports) is accepted too.

The encoders (`encode_status`, `encode_read_reply`, `encode_ack`, `encode_ir_report`, and the
button and accelerometer bytes they share) write what the remote sends: the simulated remote uses
them, and the tests check encode -> `parse` round trips. The dots inside the IR reports are
`ir_dots`' business; the ids and lengths `protocol`'s.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field

from wiithrow.vision.wiimote.ir_dots import (
    BBox,
    Dot,
    IRReportFields,
    decode_dots_basic,
    decode_dots_extended_into,
    decode_dots_full_into,
    encode_dots_basic,
    encode_dots_extended,
    encode_dots_full,
)
from wiithrow.vision.wiimote.protocol import (
    BUTTON_MASK_0,
    BUTTON_MASK_1,
    IN_ACK,
    IN_BUTTONS,
    IN_BUTTONS_ACCEL,
    IN_BUTTONS_ACCEL_EXT16,
    IN_BUTTONS_ACCEL_IR10_EXT6,
    IN_BUTTONS_ACCEL_IR12,
    IN_BUTTONS_EXT8,
    IN_BUTTONS_EXT19,
    IN_BUTTONS_IR10_EXT9,
    IN_EXT21,
    IN_INTERLEAVED_A,
    IN_INTERLEAVED_B,
    IN_READ_REPLY,
    IN_STATUS,
    INPUT_LENGTHS,
    MAX_REPORT_LENGTH,
    STATUS_BATTERY_LOW,
    STATUS_EXTENSION,
    STATUS_IR,
    STATUS_LED_MASK,
    Button,
    IRFormat,
    ProtocolError,
)

# --------------------------------------------------------------------------------------------
# The typed reports
# --------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class Report:
    """Any input report: its id and the core buttons it carries."""

    report_id: int
    buttons: Button


@dataclass(frozen=True)
class StatusReport(Report):
    """0x20 `BB BB LF 00 00 VV`: flags LF (0x01 battery low, 0x02 extension, 0x04 speaker,
    0x08 IR camera on, 0x10-0x80 LEDs 1-4) and battery level VV."""

    flags: int
    battery: int

    @property
    def ir_enabled(self) -> bool:
        return bool(self.flags & STATUS_IR)

    @property
    def battery_low(self) -> bool:
        return bool(self.flags & STATUS_BATTERY_LOW)

    @property
    def extension(self) -> bool:
        return bool(self.flags & STATUS_EXTENSION)

    @property
    def leds(self) -> int:
        return self.flags & STATUS_LED_MASK


@dataclass(frozen=True)
class ReadReply(Report):
    """0x21 `BB BB SE AA AA DD*16`: S = size - 1 (high nibble), E = error (low nibble: 0 ok,
    7 write-only register or no extension, 8 nonexistent memory), AA AA = low 16 address bits."""

    size: int
    error: int
    offset: int
    raw_data: bytes

    @property
    def data(self) -> bytes:
        """The `size` valid bytes (empty on error)."""
        return b"" if self.error else self.raw_data[: self.size]


@dataclass(frozen=True)
class Ack(Report):
    """0x22 `BB BB RR EE`: the output report RR was processed with result EE (0 = success)."""

    acked_report: int
    error: int


@dataclass(frozen=True)
class DataReport(Report):
    """A data report without IR (0x30-0x32, 0x34, 0x35, 0x3D): buttons and raw accel if present."""

    accel: tuple[int, int, int] | None = None
    extension: bytes = b""


@dataclass(frozen=True)
class IRReport(Report):
    """A data report with IR dots (0x33, 0x36, 0x37, 0x3E, 0x3F).

    `dots`: slot (0-3) -> (x, y) for the visible dots this report carries (0x3E carries slots 0-1,
    0x3F slots 2-3, the others all four); `sizes` (extended, full), `bboxes` (full:
    xmin, ymin, xmax, ymax on the 128x96 sensor, 7 bits each) and `intensities` (full) for the
    same slots. `accel`: raw (x, y, z) on the 10-bit scale (`XX << 2 | lsb`, no calibration) for
    0x33/0x37; None for 0x36 and for the interleaved reports, which carry half of it each in
    `accel_split` (0x3E: X and the high Z bits, 0x3F: Y and the low Z bits; see
    `combine_interleaved_accel`).
    """

    ir_format: IRFormat = IRFormat.EXTENDED
    dots: dict[int, Dot] = field(default_factory=dict)
    sizes: dict[int, int] = field(default_factory=dict)
    bboxes: dict[int, BBox] = field(default_factory=dict)
    intensities: dict[int, int] = field(default_factory=dict)
    accel: tuple[int, int, int] | None = None
    accel_split: tuple[int, int] | None = None

    @property
    def slots(self) -> tuple[int, ...]:
        """The dot slots this report carries (visible or not)."""
        if self.report_id == IN_INTERLEAVED_A:
            return (0, 1)
        if self.report_id == IN_INTERLEAVED_B:
            return (2, 3)
        return (0, 1, 2, 3)


# --------------------------------------------------------------------------------------------
# Buttons and accelerometer
# --------------------------------------------------------------------------------------------


def encode_buttons(buttons: int, accel: tuple[int, int, int] | None = None) -> bytes:
    """The two button bytes `BB BB`, with the accelerometer LSBs when `accel` is given:
    byte 0 bits 5-6 = x bits 1-0; byte 1 bit 5 = y bit 1, bit 6 = z bit 1 (y, z bit 0 is lost)."""
    b = int(buttons)
    b0, b1 = b & BUTTON_MASK_0, (b >> 8) & BUTTON_MASK_1
    if accel is not None:
        x, y, z = (int(v) for v in accel)
        b0 |= (x & 0x03) << 5
        b1 |= ((y >> 1) & 0x01) << 5 | ((z >> 1) & 0x01) << 6
    return bytes([b0, b1])


def decode_buttons(b0: int, b1: int) -> Button:
    key = (b0 & BUTTON_MASK_0) | (b1 & BUTTON_MASK_1) << 8
    button = _BUTTONS.get(key)
    if button is None:  # building an IntFlag costs microseconds; the 100 Hz path reuses them
        button = _BUTTONS[key] = Button(key)
    return button


_BUTTONS: dict[int, Button] = {}


def _check_accel(accel: tuple[int, int, int]) -> tuple[int, int, int]:
    x, y, z = (int(v) for v in accel)
    if not all(0 <= v <= 1023 for v in (x, y, z)):
        raise ProtocolError(f"raw accelerometer values are 10 bits, got {(x, y, z)}")
    return x, y, z


def encode_accel(accel: tuple[int, int, int]) -> bytes:
    """`XX YY ZZ`: the upper 8 bits of the 10-bit raw values (the LSBs go in the button bytes)."""
    x, y, z = _check_accel(accel)
    return bytes([x >> 2, y >> 2, z >> 2])


def decode_accel(payload: bytes) -> tuple[int, int, int]:
    """Raw (x, y, z) from a `BB BB XX YY ZZ` payload, as the kernel does: x = XX<<2 | b0 bits 5-6,
    y = YY<<2 | b1 bit 5 (as bit 1), z = ZZ<<2 | b1 bit 6 (as bit 1)."""
    x = payload[2] << 2 | (payload[0] >> 5) & 0x03
    y = payload[3] << 2 | (payload[1] >> 4) & 0x02
    z = payload[4] << 2 | (payload[1] >> 5) & 0x02
    return x, y, z


def combine_interleaved_accel(a: IRReport, b: IRReport) -> tuple[int, int, int] | None:
    """Raw (x, y, z) (10-bit scale, 8 significant bits) from a 0x3E/0x3F pair.

    0x3E: X in its accel byte, Z bits 4-5 in button byte 0 bits 5-6, Z bits 6-7 in byte 1 bits
    5-6; 0x3F: Y in its accel byte, Z bits 0-1 in byte 0 bits 5-6, Z bits 2-3 in byte 1 bits 5-6
    (`handler_drm_SKAI1/2` of the Linux driver).
    """
    if a.accel_split is None or b.accel_split is None:
        return None
    x8, z_hi = a.accel_split
    y8, z_lo = b.accel_split
    return x8 << 2, y8 << 2, (z_hi | z_lo) << 2


def _interleaved_button_bytes(buttons: int, z8: int, half: int) -> bytes:
    b0, b1 = int(buttons) & BUTTON_MASK_0, (int(buttons) >> 8) & BUTTON_MASK_1
    if half == 0:  # Z bits 4-5 -> b0 bits 5-6, Z bits 6-7 -> b1 bits 5-6
        b0 |= ((z8 >> 4) & 0x03) << 5
        b1 |= ((z8 >> 6) & 0x03) << 5
    else:  # Z bits 0-1 -> b0 bits 5-6, Z bits 2-3 -> b1 bits 5-6
        b0 |= (z8 & 0x03) << 5
        b1 |= ((z8 >> 2) & 0x03) << 5
    return bytes([b0, b1])


# --------------------------------------------------------------------------------------------
# Input report encoders (what the remote sends; used by the simulator and the tests)
# --------------------------------------------------------------------------------------------


def encode_status(buttons: int = 0, flags: int = 0, battery: int = 0) -> bytes:
    """0x20, 7 bytes: `[0x20, BB, BB, LF, 00, 00, VV]`."""
    return bytes([IN_STATUS]) + encode_buttons(buttons) + bytes([flags & 0xFF, 0, 0, battery & 0xFF])


def encode_read_reply(address: int, data: bytes, *, error: int = 0, buttons: int = 0) -> bytes:
    """0x21, 22 bytes: `[0x21, BB, BB, SE, AA, AA, 16 data bytes zero-padded]`."""
    data = bytes(data)
    if not 1 <= len(data) <= 16 and not (error and len(data) == 0):
        raise ProtocolError(f"a read reply carries 1-16 bytes, got {len(data)}")
    size = max(len(data), 1)
    se = ((size - 1) << 4) | (error & 0x0F)
    return (
        bytes([IN_READ_REPLY])
        + encode_buttons(buttons)
        + bytes([se, (address >> 8) & 0xFF, address & 0xFF])
        + data
        + bytes(16 - len(data))
    )


def encode_ack(acked_report: int, error: int = 0, *, buttons: int = 0) -> bytes:
    """0x22, 5 bytes: `[0x22, BB, BB, RR, EE]`."""
    return bytes([IN_ACK]) + encode_buttons(buttons) + bytes([acked_report & 0xFF, error & 0xFF])


def encode_ir_report(
    report_id: int,
    dots: Mapping[int, Dot],
    *,
    sizes: Mapping[int, int] | None = None,
    bboxes: Mapping[int, BBox] | None = None,
    intensities: Mapping[int, int] | None = None,
    buttons: int = 0,
    accel: tuple[int, int, int] = (512, 512, 512),
) -> bytes:
    """An IR data report.

    0x33: `[id, BB, BB, XX, YY, ZZ, 12 extended IR bytes]` (18 bytes)
    0x36: `[id, BB, BB, 10 basic IR bytes, 9 extension bytes]` (22)
    0x37: `[id, BB, BB, XX, YY, ZZ, 10 basic IR bytes, 6 extension bytes]` (22)
    0x3E: `[id, BB, BB, XX, 18 full IR bytes (slots 0-1)]` (22)
    0x3F: `[id, BB, BB, YY, 18 full IR bytes (slots 2-3)]` (22)
    Extension bytes are zero (no extension). For 0x3E/0x3F the Z byte is spread over the unused
    button bits (see `combine_interleaved_accel`) and the x/y LSBs are lost.
    """
    if report_id == IN_BUTTONS_ACCEL_IR12:
        return (
            bytes([report_id])
            + encode_buttons(buttons, accel)
            + encode_accel(accel)
            + encode_dots_extended(dots, sizes)
        )
    if report_id == IN_BUTTONS_IR10_EXT9:
        return bytes([report_id]) + encode_buttons(buttons) + encode_dots_basic(dots) + bytes(9)
    if report_id == IN_BUTTONS_ACCEL_IR10_EXT6:
        return (
            bytes([report_id])
            + encode_buttons(buttons, accel)
            + encode_accel(accel)
            + encode_dots_basic(dots)
            + bytes(6)
        )
    if report_id in (IN_INTERLEAVED_A, IN_INTERLEAVED_B):
        x8, y8, z8 = encode_accel(accel)
        half = 0 if report_id == IN_INTERLEAVED_A else 1
        slots = (0, 1) if half == 0 else (2, 3)
        return (
            bytes([report_id])
            + _interleaved_button_bytes(buttons, z8, half)
            + bytes([x8 if half == 0 else y8])
            + encode_dots_full(dots, sizes, bboxes, intensities, slots)
        )
    raise ProtocolError(f"{report_id:#04x} is not an IR report (0x33, 0x36, 0x37, 0x3E, 0x3F)")


# --------------------------------------------------------------------------------------------
# The decoder
# --------------------------------------------------------------------------------------------


def _as_bytes(report: object) -> bytes:
    if isinstance(report, (bytes, bytearray, memoryview)):
        return bytes(report)
    if isinstance(report, (list, tuple)):  # hidapi's read() returns a list of ints
        if all(isinstance(v, int) and 0 <= v <= 255 for v in report):
            return bytes(report)
        raise ProtocolError("a report given as a list must hold integers 0-255")
    raise ProtocolError(f"a report is bytes (or a list of 0-255 ints), not {type(report).__name__}")


def _extended_report(rid: int, buttons: Button, p: bytes) -> IRReport:
    """Report 0x33 from its payload `p` (`BB BB XX YY ZZ` + 12 extended IR bytes at offset 5):
    the `IRReport(rid, buttons, IRFormat.EXTENDED, dots, sizes, accel=...)` of the general path,
    its fields set in one dictionary update (the frozen dataclass's `__init__` sets them one
    `object.__setattr__` at a time and builds the unused dictionaries: a few microseconds, 100
    times a second per remote; `test_input_reports` compares the two)."""
    fields = IRReportFields()
    decode_dots_extended_into(p[5:17], 0, fields)
    rep = _new(IRReport)
    rep.__dict__.update(
        report_id=rid,
        buttons=buttons,
        ir_format=IRFormat.EXTENDED,
        dots=fields.dots,
        sizes=fields.sizes,
        bboxes={},
        intensities={},
        accel=decode_accel(p),
        accel_split=None,
    )
    return rep


_new = object.__new__


def parse(report: bytes | bytearray | memoryview | list[int]) -> Report:
    """Decode one input report (hidapi framing: byte 0 is the id).

    Returns a `StatusReport`, `ReadReply`, `Ack`, `IRReport` or `DataReport`. Raises
    `ProtocolError` for an empty report, an unknown id, or a length that is neither the id's
    length nor 22 (Windows' padding); nothing else escapes.
    """
    data = _as_bytes(report)
    if not data:
        raise ProtocolError("empty report (0 bytes): expected at least a report id")
    rid = data[0]
    length = INPUT_LENGTHS.get(rid)
    if length is None:
        raise ProtocolError(f"unknown input report id {rid:#04x} ({len(data)} bytes)")
    if len(data) != length and len(data) != MAX_REPORT_LENGTH:
        raise ProtocolError(
            f"input report {rid:#04x} must be {length} bytes (or padded to {MAX_REPORT_LENGTH}), got {len(data)}"
        )
    p = data[1:length]  # the payload, without any padding
    buttons = decode_buttons(p[0], p[1]) if rid != IN_EXT21 else Button.NONE

    if rid == IN_STATUS:  # BB BB LF 00 00 VV
        return StatusReport(rid, buttons, flags=p[2], battery=p[5])
    if rid == IN_READ_REPLY:  # BB BB SE AA AA DD*16
        return ReadReply(
            rid, buttons, size=(p[2] >> 4) + 1, error=p[2] & 0x0F, offset=p[3] << 8 | p[4], raw_data=p[5:21]
        )
    if rid == IN_ACK:  # BB BB RR EE
        return Ack(rid, buttons, acked_report=p[2], error=p[3])

    if rid == IN_BUTTONS_ACCEL_IR12:  # BB BB XX YY ZZ + 12 extended IR at payload offset 5
        return _extended_report(rid, buttons, p)
    fields = IRReportFields()
    if rid == IN_BUTTONS_IR10_EXT9:  # BB BB + 10 basic IR at offset 2 + 9 extension bytes
        return IRReport(rid, buttons, IRFormat.BASIC, decode_dots_basic(p[2:12]))
    if rid == IN_BUTTONS_ACCEL_IR10_EXT6:  # BB BB XX YY ZZ + 10 basic IR at offset 5 + 6 ext
        return IRReport(rid, buttons, IRFormat.BASIC, decode_dots_basic(p[5:15]), accel=decode_accel(p))
    if rid in (IN_INTERLEAVED_A, IN_INTERLEAVED_B):  # BB BB AA + 2 x 9 full IR at offsets 3, 12
        first = 0 if rid == IN_INTERLEAVED_A else 2
        decode_dots_full_into(p[3:21], first, fields)
        if rid == IN_INTERLEAVED_A:
            split = (p[2], (p[0] >> 1) & 0x30 | (p[1] << 1) & 0xC0)
        else:
            split = (p[2], (p[0] >> 5) & 0x03 | (p[1] >> 3) & 0x0C)
        return IRReport(
            rid,
            buttons,
            IRFormat.FULL,
            fields.dots,
            fields.sizes,
            fields.bboxes,
            fields.intensities,
            accel=None,
            accel_split=split,
        )
    # Data reports without IR.
    if rid == IN_BUTTONS:
        return DataReport(rid, buttons)
    if rid == IN_BUTTONS_ACCEL:
        return DataReport(rid, buttons, accel=decode_accel(p))
    if rid in (IN_BUTTONS_EXT8, IN_BUTTONS_EXT19):
        return DataReport(rid, buttons, extension=p[2:])
    if rid == IN_BUTTONS_ACCEL_EXT16:
        return DataReport(rid, buttons, accel=decode_accel(p), extension=p[5:])
    return DataReport(rid, buttons, extension=p)  # 0x3D: 21 extension bytes, no buttons
