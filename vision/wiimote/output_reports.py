"""The output reports (host -> remote) as bytes, and the IR camera's start sequence. No I/O.

Every report the driver sends: rumble (0x10), LEDs (0x11), reporting mode (0x12), the IR camera's
pixel clock (0x13) and logic (0x1A), status request (0x15), register/EEPROM write (0x16) and read
(0x17). Writes are exactly the report's length (never padded to 22 bytes). `ir_start_sequence` is
the Linux kernel's order of them that starts the IR camera (`docs/wiimote.md`). The ids, flags and
registers are `protocol`'s.
"""

from __future__ import annotations

from dataclasses import dataclass

from wiithrow.vision.wiimote.protocol import (
    FLAG_ACK,
    FLAG_CONTINUOUS,
    FLAG_RUMBLE,
    IN_BUTTONS,
    INPUT_LENGTHS,
    IR_CONTROL_CONFIGURE,
    IR_CONTROL_RUN,
    IR_ENABLE,
    IR_REG_BLOCK1,
    IR_REG_BLOCK2,
    IR_REG_CONTROL,
    IR_REG_MODE,
    OUT_IR_LOGIC,
    OUT_IR_PIXEL_CLOCK,
    OUT_LEDS,
    OUT_READ,
    OUT_REPORT_MODE,
    OUT_RUMBLE,
    OUT_STATUS_REQUEST,
    OUT_WRITE,
    REPORT_MODES,
    SPACE_REGISTER,
    STATUS_LED_MASK,
    IRFormat,
    ProtocolError,
    sensitivity_blocks,
)


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
