"""The Wiimote's HID protocol: its vocabulary, shared by every module that speaks it.

This module owns the identifiers and the numbers of the protocol (WiiBrew, Linux
`hid-wiimote-core.c`/`hid-wiimote-modules.c`, `docs/wiimote.md`): vendor and product ids, the
output and input report ids and their lengths, the flag bits, the core buttons, the IR formats and
the reporting modes that carry them, the IR camera's registers and its sensitivity settings, and
`ProtocolError`. The byte layouts live beside it:

- `output_reports`: what the host sends (encoders) and the IR camera's start sequence;
- `input_reports`: what the remote sends, typed, with `parse` (bytes -> report) and the encoders
  the simulated remote and the tests use;
- `ir_dots`: the IR dot formats (basic, extended, full) inside the input reports.

Framing is hidapi's: byte 0 of every report is its id; there is no Bluetooth 0xA1/0xA2 prefix.
Nothing here does I/O.
"""

from __future__ import annotations

import enum

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

# Sensitivity blocks (block 1, 9 bytes / block 2, 2 bytes): docs/wiimote.md, from WiiBrew. cwiid's
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
