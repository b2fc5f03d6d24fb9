"""The simulated remote's memory: registers, EEPROM, and the IR camera's configure/run protocol.

`RemoteMemory` is what the 0x16 writes and 0x17 reads of a `SimulatedWiimote` reach:

- the IR camera's registers 0xB00000-0xB000FF, mirrored every 0x100 bytes up to 0xB1FFFF as on the
  real camera; the other register spaces (0xA2 speaker, 0xA4 extension, 0xA6 MotionPlus: with no
  extension plugged in, reads of 0xA4 and 0xA6 fail as write-only); a 0x1700-byte EEPROM;
- the camera's state as its registers drive it (`docs/wiimote.md`). While its pixel clock and
  logic are powered (0x13 and 0x1A), 0xB00030 <- 0x01 starts a configuration; the camera runs
  after 0xB00030 <- 0x08 only if both sensitivity blocks (0xB00000-08, 0xB0001A-1B) and the mode
  byte (0xB00033) were written since; an unpowered camera ignores its bus, and cutting its power
  stops it. Whether a complete configuration brings the camera up is the remote's call
  (`on_start`: the simulator's dead-camera fault).

The error codes of failed writes and reads are the simulator's choice (the real remote's are not
documented): `ERR_MALFORMED`, `ERR_BAD_ADDRESS`, `READ_ERR_WRITE_ONLY`, `READ_ERR_NO_MEMORY`.
"""

from __future__ import annotations

from collections.abc import Callable

from wiithrow.vision.wiimote.protocol import (
    IR_CONTROL_CONFIGURE,
    IR_CONTROL_RUN,
    IR_REG_BLOCK1,
    IR_REG_BLOCK2,
    IR_REG_CONTROL,
    IR_REG_MODE,
    SPACE_REGISTER,
    IRFormat,
    sensitivity_name,
)

ERR_OK = 0x00
ERR_MALFORMED = 0x03
ERR_BAD_ADDRESS = 0x08
READ_ERR_WRITE_ONLY = 0x07
READ_ERR_NO_MEMORY = 0x08

EEPROM_SIZE = 0x1700
IR_REGION_START = 0xB00000
IR_REGION_END = 0xB20000  # exclusive; 0xB00000-0xB000FF mirrored every 0x100 bytes
REGISTER_SPACES = (0xA2, 0xA4, 0xA6)  # speaker, extension, MotionPlus (no extension present)
NO_EXTENSION_SPACES = (0xA4, 0xA6)  # reads fail as write-only: no extension is plugged in

#: Mode byte -> IR format (`RemoteMemory.ir_format`).
_FORMATS: dict[int, IRFormat] = {f.value: f for f in IRFormat}
_CONFIG_ADDRESSES = frozenset([*(IR_REG_BLOCK1 + i for i in range(9)), IR_REG_BLOCK2, IR_REG_BLOCK2 + 1, IR_REG_MODE])


class RemoteMemory:
    """Registers, EEPROM and the IR camera's run state of a simulated remote (see the module
    docstring). `on_start()` is called when a complete configuration ends with 0xB00030 <- 0x08
    and says whether the camera comes up."""

    def __init__(self, on_start: Callable[[], bool]) -> None:
        self.on_start = on_start
        self.power_on()

    def power_on(self) -> None:
        """The state of a freshly powered remote: everything zero, the camera off and unpowered."""
        self.ir_registers = bytearray(0x100)
        self.other_registers: dict[int, int] = {}
        self.eeprom = bytearray(EEPROM_SIZE)
        self.powered = False
        self.camera_running = False
        self._configuring: set[int] | None = None  # addresses written since 0xB00030 <- 0x01

    def set_power(self, on: bool) -> None:
        """The camera's pixel clock and logic are both enabled (`on`) or not; cutting the power
        stops the camera and forgets a configuration in progress."""
        self.powered = on
        if not on:
            self.camera_running = False
            self._configuring = None

    # ---------------------------------------------------------------- what the camera's registers say

    @property
    def ir_mode_byte(self) -> int:
        return self.ir_registers[IR_REG_MODE & 0xFF]

    @property
    def ir_format(self) -> IRFormat | None:
        """The camera's format from its mode byte (None for an invalid byte; a dictionary, where
        calling the enum costs a microsecond or two: asked at every report)."""
        return _FORMATS.get(self.ir_registers[IR_REG_MODE & 0xFF])

    @property
    def sensitivity(self) -> str | None:
        """The named sensitivity whose blocks are in the registers (None if custom or unset)."""
        r = self.ir_registers
        return sensitivity_name(bytes(r[0:9]), bytes(r[0x1A:0x1C]))

    @property
    def blind(self) -> bool:
        """True when the sensitivity's gain limit (block 2, byte 0) is not below its gain (block 1,
        byte 8): the camera then sees nothing."""
        return self.ir_registers[0x1A] >= self.ir_registers[0x08]

    # ---------------------------------------------------------------- 0x16 and 0x17

    def register(self, address: int, size: int = 1) -> bytes:
        """Register contents (space 0x04), as a 0x17 read would return them."""
        return bytes(self._read_byte(address + i) for i in range(size))

    def write(self, space: int, address: int, payload: bytes) -> int:
        """A 0x16 write of `payload` at `address` of register space (`space` & 0x04) or EEPROM;
        returns its error code (ERR_OK, or ERR_BAD_ADDRESS for memory that does not exist)."""
        size = len(payload)
        if space & SPACE_REGISTER:
            if not all(self._exists(address + i) for i in range(size)):
                return ERR_BAD_ADDRESS
            for i, b in enumerate(payload):
                self._write_byte(address + i, b)
        else:
            if address + size > EEPROM_SIZE:
                return ERR_BAD_ADDRESS
            self.eeprom[address : address + size] = payload
        return ERR_OK

    def read(self, space: int, address: int, size: int) -> tuple[int, bytes]:
        """A 0x17 read of `size` bytes: (error code, content); the content is empty on error
        (READ_ERR_WRITE_ONLY for the extension spaces, READ_ERR_NO_MEMORY beyond the memory)."""
        if space & SPACE_REGISTER:
            if address >> 16 in NO_EXTENSION_SPACES:
                return READ_ERR_WRITE_ONLY, b""
            if not all(self._exists(address + i) for i in range(size)):
                return READ_ERR_NO_MEMORY, b""
            return ERR_OK, self.register(address, size)
        if address + size > EEPROM_SIZE:
            return READ_ERR_NO_MEMORY, b""
        return ERR_OK, bytes(self.eeprom[address : address + size])

    @staticmethod
    def _exists(address: int) -> bool:
        return IR_REGION_START <= address < IR_REGION_END or (address >> 16) in REGISTER_SPACES

    def _read_byte(self, address: int) -> int:
        if IR_REGION_START <= address < IR_REGION_END:
            return self.ir_registers[address & 0xFF]
        return self.other_registers.get(address, 0)

    def _write_byte(self, address: int, value: int) -> None:
        if not IR_REGION_START <= address < IR_REGION_END:
            self.other_registers[address] = value
            return
        canonical = IR_REGION_START | (address & 0xFF)
        self.ir_registers[address & 0xFF] = value
        if not self.powered:
            return  # an unpowered camera ignores its bus
        if canonical == IR_REG_CONTROL:
            if value == IR_CONTROL_CONFIGURE:
                self._configuring = set()
                self.camera_running = False
            elif value == IR_CONTROL_RUN:
                complete = self._configuring is not None and self._configuring >= _CONFIG_ADDRESSES
                self._configuring = None
                self.camera_running = complete and self.on_start()
        elif self._configuring is not None:
            self._configuring.add(canonical)
