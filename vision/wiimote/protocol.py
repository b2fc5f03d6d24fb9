"""The Wiimote's HID reports as bytes: pure encoders and one decoder, no I/O.

This module owns the byte layouts (WiiBrew, Linux `hid-wiimote-core.c`/`hid-wiimote-modules.c`):
every output report the driver sends, every input report the driver reads, and the input
reports the simulated remote sends, so that encode -> `parse` round-trips are testable.

Framing is hidapi's: byte 0 of every report is its id; there is no Bluetooth 0xA1/0xA2 prefix.
Writes are exactly the report's length (never padded to 22 bytes). On reads, a report padded to
22 bytes (what Windows' HID stack returns for the remote's shorter reports) is accepted too.

`parse(report)` returns one of the typed reports below or raises `ProtocolError` (a
`VisionError`, hence a `ValueError`) naming the report id and the expected and actual length;
nothing else ever escapes it.

Decoded dots follow the project's conventions: pixel coordinates 0..1023 x 0..767, and a missing
dot is simply absent from `dots` (the driver turns that into NaN). On the wire a missing dot is
sent as all 0xFF (x or y = 1023); newer remotes sometimes send (0, 0) for a blob they have not
measured yet: both are missing here. A y beyond the sensor (768..1022) cannot be a real dot and is
treated as missing as well.
"""

from __future__ import annotations

import enum
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field

from wiithrow.vision.errors import VisionError

# --------------------------------------------------------------------------------------------
# Identifiers
# --------------------------------------------------------------------------------------------

VENDOR_ID = 0x057E
PRODUCT_WIIMOTE = 0x0306  # RVL-CNT-01
PRODUCT_WIIMOTE_PLUS = 0x0330  # RVL-CNT-01-TR (Wii Remote Plus, MotionPlus inside)
MODEL_NAMES = {PRODUCT_WIIMOTE: "RVL-CNT-01", PRODUCT_WIIMOTE_PLUS: "RVL-CNT-01-TR"}

MAX_REPORT_LENGTH = 22  # the longest report, id included; Windows pads shorter input reports to it

# Output reports (host -> remote). Bit 0x01 of the first payload byte is rumble in all of them.
OUT_RUMBLE = 0x10
OUT_LEDS = 0x11
OUT_REPORT_MODE = 0x12
OUT_IR_PIXEL_CLOCK = 0x13
OUT_SPEAKER_ENABLE = 0x14
OUT_STATUS_REQUEST = 0x15
OUT_WRITE = 0x16
OUT_READ = 0x17
OUT_SPEAKER_DATA = 0x18
OUT_SPEAKER_MUTE = 0x19
OUT_IR_LOGIC = 0x1A

# Total length (id included) of every output report.
OUTPUT_LENGTHS: dict[int, int] = {
    OUT_RUMBLE: 2,
    OUT_LEDS: 2,
    OUT_REPORT_MODE: 3,
    OUT_IR_PIXEL_CLOCK: 2,
    OUT_SPEAKER_ENABLE: 2,
    OUT_STATUS_REQUEST: 2,
    OUT_WRITE: 22,
    OUT_READ: 7,
    OUT_SPEAKER_DATA: 22,
    OUT_SPEAKER_MUTE: 2,
    OUT_IR_LOGIC: 2,
}

# Flag bits of the first payload byte of output reports.
FLAG_RUMBLE = 0x01
FLAG_ACK = 0x02  # ask the remote for a 0x22 acknowledgement (0x16 writes are always acknowledged)
FLAG_ENABLE = 0x04  # 0x13/0x1A: enable; 0x12: continuous reporting; 0x16/0x17: register space
FLAG_CONTINUOUS = 0x04
SPACE_EEPROM = 0x00
SPACE_REGISTER = 0x04

# Input reports (remote -> host).
IN_STATUS = 0x20
IN_READ_REPLY = 0x21
IN_ACK = 0x22
IN_BUTTONS = 0x30
IN_BUTTONS_ACCEL = 0x31
IN_BUTTONS_EXT8 = 0x32
IN_BUTTONS_ACCEL_IR12 = 0x33  # extended IR
IN_BUTTONS_EXT19 = 0x34
IN_BUTTONS_ACCEL_EXT16 = 0x35
IN_BUTTONS_IR10_EXT9 = 0x36  # basic IR
IN_BUTTONS_ACCEL_IR10_EXT6 = 0x37  # basic IR
IN_EXT21 = 0x3D
IN_INTERLEAVED_A = 0x3E  # full IR, dot slots 0-1
IN_INTERLEAVED_B = 0x3F  # full IR, dot slots 2-3

# Total length (id included) of every input report.
INPUT_LENGTHS: dict[int, int] = {
    IN_STATUS: 7,
    IN_READ_REPLY: 22,
    IN_ACK: 5,
    IN_BUTTONS: 3,
    IN_BUTTONS_ACCEL: 6,
    IN_BUTTONS_EXT8: 11,
    IN_BUTTONS_ACCEL_IR12: 18,
    IN_BUTTONS_EXT19: 22,
    IN_BUTTONS_ACCEL_EXT16: 22,
    IN_BUTTONS_IR10_EXT9: 22,
    IN_BUTTONS_ACCEL_IR10_EXT6: 22,
    IN_EXT21: 22,
    IN_INTERLEAVED_A: 22,
    IN_INTERLEAVED_B: 22,
}

# Status report flags (byte LF of `BB BB LF 00 00 VV`).
STATUS_BATTERY_LOW = 0x01
STATUS_EXTENSION = 0x02
STATUS_SPEAKER = 0x04
STATUS_IR = 0x08
STATUS_LED_MASK = 0xF0

# Player LEDs of report 0x11 (and of the status flags): LED n is bit 0x10 << (n - 1).
LED_BITS = (0x10, 0x20, 0x40, 0x80)


def player_leds(player: int) -> int:
    """The LED bits that show `player` (1-4): 0x10, 0x20, 0x40 or 0x80."""
    if not 1 <= int(player) <= 4:
        raise ProtocolError(f"player must be 1-4, got {player}")
    return LED_BITS[int(player) - 1]


# --------------------------------------------------------------------------------------------
# Errors, buttons, IR formats, registers
# --------------------------------------------------------------------------------------------


class ProtocolError(VisionError):
    """Bytes that are not a valid Wiimote report (unknown id, wrong length, empty), or a request
    that cannot be encoded (too much data, address out of range)."""


class Button(enum.IntFlag):
    """The core buttons, as the 16-bit value `byte0 | byte1 << 8` of the first two payload bytes.

    byte 0: 0x01 Left, 0x02 Right, 0x04 Down, 0x08 Up, 0x10 Plus;
    byte 1: 0x01 Two, 0x02 One, 0x04 B, 0x08 A, 0x10 Minus, 0x80 Home.
    The other bits (0x60 of each byte) carry accelerometer LSBs and are not buttons.
    """

    NONE = 0
    LEFT = 0x0001
    RIGHT = 0x0002
    DOWN = 0x0004
    UP = 0x0008
    PLUS = 0x0010
    TWO = 0x0100
    ONE = 0x0200
    B = 0x0400
    A = 0x0800
    MINUS = 0x1000
    HOME = 0x8000


BUTTON_MASK_0 = 0x1F
BUTTON_MASK_1 = 0x9F


class IRFormat(enum.Enum):
    """The IR camera's data formats; the value is the mode byte written to 0xB00033."""

    BASIC = 1  # 10 bytes for 4 dots: x, y only
    EXTENDED = 3  # 12 bytes: x, y, size
    FULL = 5  # 36 bytes over two reports: x, y, size, bounding box, intensity

    @classmethod
    def from_name(cls, name: str | IRFormat) -> IRFormat:
        if isinstance(name, IRFormat):
            return name
        try:
            return cls[str(name).upper()]
        except KeyError:
            raise ProtocolError(f"unknown IR format {name!r}: choose one of basic, extended, full") from None


IR_MODE_BASIC = IRFormat.BASIC.value
IR_MODE_EXTENDED = IRFormat.EXTENDED.value
IR_MODE_FULL = IRFormat.FULL.value

# Which reporting modes (0x12) carry which IR format. The camera's format must match the report
# mode, or the remote sends no usable dots. For the full format the host selects 0x3E and the
# remote alternates 0x3E/0x3F.
REPORT_MODES: dict[IRFormat, tuple[int, ...]] = {
    IRFormat.BASIC: (IN_BUTTONS_IR10_EXT9, IN_BUTTONS_ACCEL_IR10_EXT6),
    IRFormat.EXTENDED: (IN_BUTTONS_ACCEL_IR12,),
    IRFormat.FULL: (IN_INTERLEAVED_A,),
}
IR_REPORT_IDS: dict[int, IRFormat] = {
    IN_BUTTONS_IR10_EXT9: IRFormat.BASIC,
    IN_BUTTONS_ACCEL_IR10_EXT6: IRFormat.BASIC,
    IN_BUTTONS_ACCEL_IR12: IRFormat.EXTENDED,
    IN_INTERLEAVED_A: IRFormat.FULL,
    IN_INTERLEAVED_B: IRFormat.FULL,
}


def ir_format_of_report_mode(mode: int) -> IRFormat | None:
    """The IR format a reporting mode carries (0x3F counts as full), or None for non-IR modes."""
    return IR_REPORT_IDS.get(mode)


# IR camera registers (register space 0x04).
IR_REG_BLOCK1 = 0xB00000  # sensitivity block 1, 9 bytes
IR_REG_BLOCK2 = 0xB0001A  # sensitivity block 2, 2 bytes
IR_REG_CONTROL = 0xB00030  # 0x01 before configuring, 0x08 when done
IR_REG_MODE = 0xB00033  # 1 basic, 3 extended, 5 full
IR_CONTROL_CONFIGURE = 0x01
IR_CONTROL_RUN = 0x08
IR_ENABLE = 0x04  # payload of 0x13 / 0x1A that enables; 0x06 asks for an acknowledgement as well

# Sensitivity blocks (block 1, 9 bytes / block 2, 2 bytes): DESIGN.md, from WiiBrew. cwiid's
# level 5 starts with 0x02 and WimoteLib's level-5 block 2 is wrong: these are the right ones.
SENSITIVITY_BLOCKS: dict[str, tuple[bytes, bytes]] = {
    "level1": (bytes.fromhex("02 00 00 71 01 00 64 00 FE"), bytes.fromhex("FD 05")),
    "level2": (bytes.fromhex("02 00 00 71 01 00 96 00 B4"), bytes.fromhex("B3 04")),
    "level3": (bytes.fromhex("02 00 00 71 01 00 AA 00 64"), bytes.fromhex("63 03")),
    "level4": (bytes.fromhex("02 00 00 71 01 00 C8 00 36"), bytes.fromhex("35 03")),
    "level5": (bytes.fromhex("07 00 00 71 01 00 72 00 20"), bytes.fromhex("1F 03")),
    "marcan": (bytes.fromhex("00 00 00 00 00 00 90 00 C0"), bytes.fromhex("40 00")),
    "max": (bytes.fromhex("00 00 00 00 00 00 FF 00 0C"), bytes.fromhex("00 00")),
}
DEFAULT_SENSITIVITY = "level3"  # the kernel's and wiiuse's default


def sensitivity_blocks(name: str) -> tuple[bytes, bytes]:
    """Block 1 (9 bytes) and block 2 (2 bytes) of a named sensitivity setting."""
    try:
        return SENSITIVITY_BLOCKS[str(name).lower()]
    except KeyError:
        raise ProtocolError(f"unknown IR sensitivity {name!r}: choose one of {', '.join(SENSITIVITY_BLOCKS)}") from None


def sensitivity_name(block1: bytes, block2: bytes) -> str | None:
    """The name of the setting whose blocks these are, or None for a custom setting."""
    for name, (b1, b2) in SENSITIVITY_BLOCKS.items():
        if bytes(block1) == b1 and bytes(block2) == b2:
            return name
    return None


# --------------------------------------------------------------------------------------------
# Output reports (host -> remote)
# --------------------------------------------------------------------------------------------


def _flags(rumble: bool, ack: bool = False) -> int:
    return (FLAG_RUMBLE if rumble else 0) | (FLAG_ACK if ack else 0)


def encode_rumble(on: bool) -> bytes:
    """0x10 `[RR]`: rumble on/off."""
    return bytes([OUT_RUMBLE, _flags(on)])


def encode_leds(leds: int, *, rumble: bool = False, ack: bool = False) -> bytes:
    """0x11 `[LL]`: LED bits 0x10/0x20/0x40/0x80 (players 1-4), plus the rumble/ack bits."""
    if not 0 <= leds <= 0xFF or leds & ~STATUS_LED_MASK:
        raise ProtocolError(f"LED bits must be a combination of 0x10, 0x20, 0x40, 0x80; got {leds:#x}")
    return bytes([OUT_LEDS, leds | _flags(rumble, ack)])


def encode_report_mode(mode: int, *, continuous: bool = True, rumble: bool = False, ack: bool = False) -> bytes:
    """0x12 `[TT, MM]`: TT bit 0x04 = report continuously, MM = input report id to send."""
    if mode not in INPUT_LENGTHS or mode < IN_BUTTONS:
        raise ProtocolError(f"{mode:#04x} is not a data reporting mode (0x30-0x3F)")
    return bytes([OUT_REPORT_MODE, (FLAG_CONTINUOUS if continuous else 0) | _flags(rumble, ack), mode])


def encode_ir_pixel_clock(enable: bool = True, *, ack: bool = True, rumble: bool = False) -> bytes:
    """0x13 `[0x04 | 0x02 ack | 0x01 rumble]`: the camera's 24 MHz pixel clock."""
    return bytes([OUT_IR_PIXEL_CLOCK, (IR_ENABLE if enable else 0) | _flags(rumble, ack)])


def encode_ir_logic(enable: bool = True, *, ack: bool = True, rumble: bool = False) -> bytes:
    """0x1A `[0x04 | 0x02 ack | 0x01 rumble]`: the camera's logic (enable line)."""
    return bytes([OUT_IR_LOGIC, (IR_ENABLE if enable else 0) | _flags(rumble, ack)])


def encode_status_request(*, rumble: bool = False) -> bytes:
    """0x15 `[RR]`: ask for a 0x20 status report."""
    return bytes([OUT_STATUS_REQUEST, _flags(rumble)])


def _check_address(address: int) -> None:
    if not 0 <= int(address) <= 0xFFFFFF:
        raise ProtocolError(f"address {address:#x} does not fit in 24 bits")


def encode_write(address: int, data: bytes, *, space: int = SPACE_REGISTER, rumble: bool = False) -> bytes:
    """0x16, 22 bytes: `[SS, A2, A1, A0, size, 16 data bytes zero-padded]`, SS 0x04 = registers."""
    data = bytes(data)
    _check_address(address)
    if not 1 <= len(data) <= 16:
        raise ProtocolError(f"a write carries 1-16 bytes, got {len(data)}")
    head = bytes(
        [OUT_WRITE, space | _flags(rumble), (address >> 16) & 0xFF, (address >> 8) & 0xFF, address & 0xFF, len(data)]
    )
    return head + data + bytes(16 - len(data))


def encode_read(address: int, size: int, *, space: int = SPACE_REGISTER, rumble: bool = False) -> bytes:
    """0x17, 7 bytes: `[SS, A2, A1, A0, size_hi, size_lo]`; replies come as 0x21, 16 bytes each."""
    _check_address(address)
    if not 1 <= int(size) <= 0xFFFF:
        raise ProtocolError(f"a read asks for 1-65535 bytes, got {size}")
    return bytes(
        [
            OUT_READ,
            space | _flags(rumble),
            (address >> 16) & 0xFF,
            (address >> 8) & 0xFF,
            address & 0xFF,
            (size >> 8) & 0xFF,
            size & 0xFF,
        ]
    )


@dataclass(frozen=True)
class StartStep:
    """One output report of the IR start sequence, and whether the remote acknowledges it."""

    report: bytes
    expects_ack: bool
    what: str


def ir_start_sequence(sensitivity: str, ir_format: IRFormat | str, report_mode: int | None = None) -> list[StartStep]:
    """The IR camera start sequence in the Linux kernel's order (`wiimod_ir_change`).

    0x13 <- 0x06 (ack), 0x1A <- 0x06 (ack), 0xB00030 <- 0x01, 0xB00000 <- block 1,
    0xB0001A <- block 2, 0xB00033 <- mode, 0xB00030 <- 0x08 (each write acknowledged), then 0x12
    with the continuous flag and the report mode matching the format (not acknowledged: the IR
    reports that follow are the confirmation).
    """
    fmt = IRFormat.from_name(ir_format)
    block1, block2 = sensitivity_blocks(sensitivity)
    mode = REPORT_MODES[fmt][-1] if report_mode is None else int(report_mode)
    if mode not in REPORT_MODES[fmt]:
        raise ProtocolError(
            f"report mode {mode:#04x} does not carry the {fmt.name.lower()} IR format; use one of "
            + ", ".join(f"{m:#04x}" for m in REPORT_MODES[fmt])
        )
    return [
        StartStep(encode_ir_pixel_clock(True, ack=True), True, "IR pixel clock (0x13)"),
        StartStep(encode_ir_logic(True, ack=True), True, "IR logic (0x1A)"),
        StartStep(encode_write(IR_REG_CONTROL, bytes([IR_CONTROL_CONFIGURE])), True, "0xB00030 <- 0x01"),
        StartStep(encode_write(IR_REG_BLOCK1, block1), True, "sensitivity block 1 at 0xB00000"),
        StartStep(encode_write(IR_REG_BLOCK2, block2), True, "sensitivity block 2 at 0xB0001A"),
        StartStep(encode_write(IR_REG_MODE, bytes([fmt.value])), True, f"mode {fmt.value} at 0xB00033"),
        StartStep(encode_write(IR_REG_CONTROL, bytes([IR_CONTROL_RUN])), True, "0xB00030 <- 0x08"),
        StartStep(encode_report_mode(mode, continuous=True), False, f"reporting mode {mode:#04x}"),
    ]


# --------------------------------------------------------------------------------------------
# Input reports: the typed results of `parse`
# --------------------------------------------------------------------------------------------

Dot = tuple[int, int]
BBox = tuple[int, int, int, int]


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
# Dot formats
# --------------------------------------------------------------------------------------------

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


def _decode_extended_into(ir: bytes, first_slot: int, out: IRReportFields) -> None:
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


def _decode_full_into(ir: bytes, first_slot: int, out: IRReportFields) -> None:
    for k in range(len(ir) // 9):
        b = ir[9 * k : 9 * k + 9]
        x, y, size = _decode_dot_extended(b[:3])
        if _present(x, y):
            s = first_slot + k
            out.dots[s] = (x, y)
            out.sizes[s] = size
            out.bboxes[s] = (b[3] & 0x7F, b[4] & 0x7F, b[5] & 0x7F, b[6] & 0x7F)
            out.intensities[s] = b[8]


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


def expected_length(report_id: int) -> int | None:
    """The length (id included) of an input report, or None for an unknown id."""
    return INPUT_LENGTHS.get(report_id)


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

    fields = IRReportFields()
    if rid == IN_BUTTONS_ACCEL_IR12:  # BB BB XX YY ZZ + 12 extended IR at payload offset 5
        _decode_extended_into(p[5:17], 0, fields)
        return IRReport(rid, buttons, IRFormat.EXTENDED, fields.dots, fields.sizes, accel=decode_accel(p))
    if rid == IN_BUTTONS_IR10_EXT9:  # BB BB + 10 basic IR at offset 2 + 9 extension bytes
        return IRReport(rid, buttons, IRFormat.BASIC, decode_dots_basic(p[2:12]))
    if rid == IN_BUTTONS_ACCEL_IR10_EXT6:  # BB BB XX YY ZZ + 10 basic IR at offset 5 + 6 ext
        return IRReport(rid, buttons, IRFormat.BASIC, decode_dots_basic(p[5:15]), accel=decode_accel(p))
    if rid in (IN_INTERLEAVED_A, IN_INTERLEAVED_B):  # BB BB AA + 2 x 9 full IR at offsets 3, 12
        first = 0 if rid == IN_INTERLEAVED_A else 2
        _decode_full_into(p[3:21], first, fields)
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
