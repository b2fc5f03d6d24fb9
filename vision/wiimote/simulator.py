"""A simulated Wiimote that speaks the real remote's HID protocol, byte for byte.

`SimulatedWiimote` is a `Transport`: the driver writes output reports to it and reads input
reports from it exactly as from hidapi. It owns the remote's side of the protocol:

- register memory: the IR camera's registers 0xB00000-0xB000FF (mirrored every 0x100 bytes up to
  0xB1FFFF, as on the real camera), other register spaces (0xA2 speaker, 0xA4 extension, 0xA6
  MotionPlus) and a 0x1700-byte EEPROM, written with 0x16 and read back with 0x17 (0x21
  replies, 16-byte chunks);
- acknowledgements: every 0x16 write is answered with 0x22 `BB BB 16 EE` (EE 0 on success, 0x03
  for a malformed write, 0x08 for an address that does not exist); any other output report whose
  first payload byte has the 0x02 bit set is acknowledged too (that is why the kernel enables the
  camera with 0x06 rather than 0x04), except 0x15 and 0x17, which are answered with their
  reports; a malformed or unknown output report is answered with error 0x03 (the real remote's
  error codes are not documented: these are the simulator's choice);
- status: 0x15 is answered with 0x20 `BB BB LF 00 00 VV` (LF: LED bits, 0x08 while the camera's
  pixel clock and logic are enabled, 0x01 when the battery is low);
- the player LEDs, rumble and the reporting mode;
- the IR camera. It streams NOTHING until it has been started with the complete sequence:
  0x13 and 0x1A enabled (payload 0x04 or 0x06), 0xB00030 <- 0x01, both sensitivity blocks
  (0xB00000-08, 0xB0001A-1B) and the mode byte (0xB00033) written, 0xB00030 <- 0x08, and a
  reporting mode (0x12) whose IR format matches the mode byte (basic 1 -> 0x36/0x37, extended
  3 -> 0x33, full 5 -> 0x3E). A mismatch, an unknown mode byte or a missing step leaves the
  camera silent, as real ones are. A sensitivity whose gain limit (block 2, byte 0) is not below
  its gain (block 1, byte 8) gives a camera that streams reports without ever seeing a dot.

Streaming: report k of a stream is due at t0 + k * 0.01 s on the injected clock (t0 = when the
stream started plus `phase_s`: two remotes are not synchronised, their report clocks have
arbitrary phases). `read()` returns the oldest due report; with a `SimClock` it never blocks (b""
when nothing is due); with `realtime=True` it waits up to its timeout for the next due report
(for the demo on a `SystemClock`). Reports the caller does not read pile up in a bounded buffer
(`buffer_size`, default 64 like Linux hidraw), the oldest dropped first (as hidapi's libusb
backend does). In the full format the remote alternates 0x3E (slots 0-1) and 0x3F (slots 2-3)
at 100 reports per second, both halves of one camera frame: complete frames arrive at 50 Hz.

Dots come from a `WiimoteCamera` looking at the world's IR sources: `sources(t)` gives their
positions (M, 3) in the camera's mount frame at time t; `camera.observe` adds pixel noise
(`sigma_px`) and rounds; `camera.blob_sizes` gives the sizes. A dot at x = 1023 or at (0, 0)
cannot be told from "missing" on the wire, so the simulated camera does not report one. Like the
real camera's tracker, a blob keeps its slot while it stays visible and a new blob takes the
lowest free slot; at most four. The full format's bounding box (7 bits per value, on the
128x96 sensor) and intensity are derived from the blob size.

Faults for tests (`SimFaults`, and methods): a camera that comes up dead (ignores the first
`dead_starts` start sequences: "on but not taking data"), dropped reports (probability), (0, 0)
dots (for missing slots and/or a new blob's first report), lost acknowledgements, a camera that
stalls mid-stream (`stall_at`), garbage reports (random bytes, unknown ids, truncated reports)
mixed into the stream, unsolicited status reports (after which the remote stops reporting until
0x12 is sent again, per WiiBrew), and disconnects: `read`/`write` raise `OSError` as hidapi does when the device vanishes, `open`
fails until the remote is back, and it comes back power-cycled (registers cleared, camera off).
`history` records what each sent data report carried (slot -> source index and pixel) so tests
can compare decoded dots with the truth.
"""

from __future__ import annotations

import heapq
import math
import threading
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass, field, replace

import numpy as np

from wiithrow.clock import Clock
from wiithrow.vision.camera import WiimoteCamera
from wiithrow.vision.wiimote.input_reports import encode_ack, encode_ir_report, encode_read_reply, encode_status
from wiithrow.vision.wiimote.ir_dots import MISSING, BBox, Dot
from wiithrow.vision.wiimote.protocol import (
    FLAG_ACK,
    FLAG_CONTINUOUS,
    FLAG_RUMBLE,
    IN_BUTTONS,
    IN_INTERLEAVED_A,
    IN_INTERLEAVED_B,
    INPUT_LENGTHS,
    IR_CONTROL_CONFIGURE,
    IR_CONTROL_RUN,
    IR_ENABLE,
    IR_REG_BLOCK1,
    IR_REG_BLOCK2,
    IR_REG_CONTROL,
    IR_REG_MODE,
    MAX_REPORT_LENGTH,
    OUT_IR_LOGIC,
    OUT_IR_PIXEL_CLOCK,
    OUT_LEDS,
    OUT_READ,
    OUT_REPORT_MODE,
    OUT_STATUS_REQUEST,
    OUT_WRITE,
    OUTPUT_LENGTHS,
    PRODUCT_WIIMOTE,
    REPORT_MODES,
    SPACE_REGISTER,
    STATUS_BATTERY_LOW,
    STATUS_IR,
    STATUS_LED_MASK,
    IRFormat,
    sensitivity_name,
)

REPORT_PERIOD_S = 0.01  # 100 reports per second
HID_BUFFER_SIZE = 64
EPS = 1e-9

ERR_OK = 0x00
ERR_MALFORMED = 0x03
ERR_BAD_ADDRESS = 0x08
READ_ERR_WRITE_ONLY = 0x07
READ_ERR_NO_MEMORY = 0x08

EEPROM_SIZE = 0x1700
IR_REGION_START = 0xB00000
IR_REGION_END = 0xB20000  # exclusive; 0xB00000-0xB000FF mirrored every 0x100 bytes
REGISTER_SPACES = (0xA2, 0xA4, 0xA6)  # speaker, extension, MotionPlus (no extension present)

_CONFIG_ADDRESSES = frozenset([*(IR_REG_BLOCK1 + i for i in range(9)), IR_REG_BLOCK2, IR_REG_BLOCK2 + 1, IR_REG_MODE])


@dataclass
class SimFaults:
    """Faults to inject (all off by default)."""

    dead_starts: int = 0  # complete start sequences the camera ignores before it comes up
    drop_probability: float = 0.0  # each due data report is lost with this probability
    garbage_probability: float = 0.0  # before each data report, a malformed report with this probability
    zero_missing: bool = False  # missing slots are sent as (0, 0) instead of all 0xFF
    zero_first: bool = False  # a blob's first report shows it at (0, 0)
    lost_acks: int = 0  # the next n acknowledgements never arrive
    stall_at: float | None = None  # the camera stops sending at this time until started again
    disconnect_at: float | None = None  # the remote vanishes at this time (clock seconds)
    reconnect_after: float | None = 1.0  # ... and can be opened again this long after (None: never)


@dataclass
class SimStats:
    """What the simulated remote did (for tests)."""

    data_reports: int = 0  # data reports put in the HID buffer
    dropped: int = 0  # data reports lost on the air (fault)
    overflowed: int = 0  # reports lost because the HID buffer was full
    garbage: int = 0
    acks: int = 0
    lost_acks: int = 0
    status_replies: int = 0
    read_replies: int = 0
    writes: int = 0
    starts: int = 0  # complete start sequences
    starts_ignored: int = 0  # ... of which the camera ignored (dead-camera fault)
    disconnects: int = 0
    opens: int = 0


@dataclass(frozen=True)
class SentReport:
    """One data report as the remote produced it (also when lost): the truth behind the bytes."""

    k: int  # index in its stream
    t: float  # due time on the clock
    report_id: int
    slots: dict[int, tuple[int, int, int]]  # slot -> (source index, x, y) of the dots it carries
    dropped: bool = False
    stream: int = 0  # which stream (increments at every stream start)


@dataclass
class _Frame:
    slots: dict[int, tuple[int, int, int]] = field(default_factory=dict)  # slot -> (src, x, y)
    sizes: dict[int, int] = field(default_factory=dict)
    new: set[int] = field(default_factory=set)  # slots whose blob appeared in this frame


class SimulatedWiimote:
    """A Wiimote at the HID-report level (see the module docstring); a `Transport`."""

    def __init__(
        self,
        camera: WiimoteCamera,
        sources: Callable[[float], np.ndarray],
        clock: Clock,
        rng: np.random.Generator,
        *,
        sigma_px: float = 0.5,
        dot_dropout: float = 0.0,
        realtime: bool = False,
        buffer_size: int = HID_BUFFER_SIZE,
        response_latency_s: float = 0.0,
        phase_s: float = 0.0,
        battery: int = 0xC0,
        product_id: int = PRODUCT_WIIMOTE,
        buttons: Callable[[float], int] | None = None,
        accel: tuple[int, int, int] = (512, 512, 616),
        faults: SimFaults | None = None,
        history_size: int = 100_000,
    ) -> None:
        if buffer_size < 1:
            raise ValueError("buffer_size must be at least 1")
        self.camera = camera
        self.sources = sources
        self.clock = clock
        self.rng = rng
        self.sigma_px = float(sigma_px)
        self.dot_dropout = float(dot_dropout)
        self.realtime = bool(realtime)
        self.buffer_size = int(buffer_size)
        self.response_latency_s = float(response_latency_s)
        if not 0.0 <= phase_s < REPORT_PERIOD_S:
            raise ValueError(f"phase_s must lie in [0, {REPORT_PERIOD_S}) s, got {phase_s}")
        self.phase_s = float(phase_s)
        self.battery = int(battery) & 0xFF
        self.product_id = int(product_id)
        self.buttons_fn = buttons
        self.accel = tuple(int(v) for v in accel)
        self.faults = replace(faults) if faults is not None else SimFaults()  # a copy: faults get used up
        self.stats = SimStats()
        self.history: deque[SentReport] = deque(maxlen=history_size)
        self.writes_log: list[bytes] = []  # every output report received, in order

        self._lock = threading.RLock()
        self._open = False
        self._vanished = False
        self._back_at: float | None = None
        self._dead_remaining = int(self.faults.dead_starts)
        self._seq = 0
        self._stream_id = 0
        self._pending: list[tuple[float, int, bytes]] = []  # heap of responses not yet due
        self._buffer: deque[bytes] = deque()  # due reports waiting to be read (the HID buffer)
        self._power_on()

    # ---------------------------------------------------------------- state of the remote

    def _power_on(self) -> None:
        """The state of a freshly connected remote."""
        self.ir_registers = bytearray(0x100)
        self.other_registers: dict[int, int] = {}
        self.eeprom = bytearray(EEPROM_SIZE)
        self.leds = 0
        self.rumble = False
        self.report_mode: int | None = None  # None: the power-on 0x30 (buttons on change only)
        self.continuous = False
        self.pixel_clock = False
        self.ir_logic = False
        self.camera_running = False
        self._cfg_written: set[int] | None = None  # addresses written since 0xB00030 <- 0x01
        self._awaiting_mode = False
        self._streaming = False
        self._t0 = 0.0
        self._k = 0
        self._slot_sources: list[int | None] = [None] * 4
        self._pending_full: _Frame | None = None
        self._buffer.clear()
        self._pending.clear()

    @property
    def ir_mode_byte(self) -> int:
        return self.ir_registers[IR_REG_MODE & 0xFF]

    @property
    def sensitivity(self) -> str | None:
        """The named sensitivity whose blocks are in the registers (None if custom or unset)."""
        r = self.ir_registers
        return sensitivity_name(bytes(r[0:9]), bytes(r[0x1A:0x1C]))

    @property
    def is_open(self) -> bool:
        return self._open

    @property
    def connected(self) -> bool:
        """False while the remote has vanished (disconnect fault)."""
        with self._lock:
            self._check_schedule(self.clock.now())
            return not self._vanished

    @property
    def streaming(self) -> bool:
        """Whether the remote is sending IR data reports right now."""
        with self._lock:
            self._check_schedule(self.clock.now())
            return self._streaming and not self._vanished

    def register(self, address: int, size: int = 1) -> bytes:
        """Register contents (space 0x04), as a 0x17 read would return them."""
        return bytes(self._reg_read(address + i) or 0 for i in range(size))

    # ---------------------------------------------------------------- faults

    def disconnect(self, duration: float | None = 1.0) -> None:
        """The remote vanishes now and can be opened again after `duration` s (None: never)."""
        with self._lock:
            self._vanish(self.clock.now(), duration)

    def send_unsolicited_status(self) -> None:
        """A status report the host did not ask for (as on extension hot-plug): the remote stops
        sending data reports until the host sends 0x12 again."""
        with self._lock:
            now = self.clock.now()
            self._catch_up(now)
            self._respond(now, self._status_report())
            self._awaiting_mode = True
            self._update_stream(now)

    def _vanish(self, now: float, duration: float | None) -> None:
        self._catch_up(now)
        self._vanished = True
        self._open = False
        self._back_at = None if duration is None else now + duration
        self.stats.disconnects += 1
        self._power_on()  # the remote comes back power-cycled

    def _check_schedule(self, now: float) -> None:
        f = self.faults
        if f.stall_at is not None and now >= f.stall_at - EPS:
            at, f.stall_at = f.stall_at, None
            self._catch_up(at)
            self.camera_running = False  # "on but not taking data" until the next start sequence
            self._update_stream(at)
        if f.disconnect_at is not None and now >= f.disconnect_at - EPS:
            at, f.disconnect_at = f.disconnect_at, None
            self._catch_up(at)
            self._vanish(at, f.reconnect_after)

    # ---------------------------------------------------------------- Transport

    def open(self) -> None:
        with self._lock:
            now = self.clock.now()
            self._check_schedule(now)
            if self._vanished:
                if self._back_at is None or now < self._back_at - EPS:
                    raise OSError("open failed")
                self._vanished = False
                self._back_at = None
            if not self._open:
                self._open = True
                self.stats.opens += 1
                self._buffer.clear()  # nothing was buffered for a closed handle
                self._pending.clear()
                self._update_stream(now)

    def close(self) -> None:
        with self._lock:
            self._open = False
            self._update_stream(self.clock.now())  # what the remote sends now reaches no one

    def write(self, data: bytes) -> int:
        with self._lock:
            now = self.clock.now()
            self._alive(now, "write")
            data = bytes(data)
            if not data:
                raise OSError("write of an empty report")
            self._catch_up(now)
            self.writes_log.append(data)
            self._handle_output(now, data)
            self._update_stream(now)
            return len(data)

    def read(self, max_size: int = MAX_REPORT_LENGTH, timeout_ms: int = 0) -> bytes:
        with self._lock:
            now = self.clock.now()
            self._alive(now, "read")
            self._catch_up(now)
            if self._buffer:
                return self._buffer.popleft()[: max(0, int(max_size))]
            if not self.realtime or timeout_ms <= 0:
                return b""
            deadline = now + timeout_ms / 1000.0
        while True:  # real-time mode: wait (without the lock) for the next due report
            with self._lock:
                now = self.clock.now()
                self._alive(now, "read")
                self._catch_up(now)
                if self._buffer:
                    return self._buffer.popleft()[: max(0, int(max_size))]
                if now >= deadline - EPS:
                    return b""
                wake = min(deadline, self._next_due(now))
            self.clock.sleep(max(wake - now, 0.0005))

    def _alive(self, now: float, what: str) -> None:
        self._check_schedule(now)
        if self._vanished:
            raise OSError(f"{what} error: the remote has disconnected")
        if not self._open:
            raise OSError(f"{what} error: the device is not open")

    def _next_due(self, now: float) -> float:
        t = math.inf
        if self._pending:
            t = self._pending[0][0]
        if self._streaming:
            t = min(t, self._t0 + self._k * REPORT_PERIOD_S)
        for at in (self.faults.disconnect_at, self.faults.stall_at):
            if at is not None:
                t = min(t, at)
        return t

    # ---------------------------------------------------------------- the HID buffer

    def _respond(self, now: float, report: bytes) -> None:
        """Queue an immediate reply (ack, status, read data) after the configured latency."""
        self._seq += 1
        heapq.heappush(self._pending, (now + self.response_latency_s, self._seq, report))

    def _catch_up(self, now: float) -> None:
        """Produce every data report due by `now` and move due reports into the HID buffer."""
        if self._streaming:
            n_due = math.floor((now - self._t0) / REPORT_PERIOD_S + EPS) + 1 - self._k
            if n_due > 2 * self.buffer_size:  # the caller was away: these would overflow anyway
                skip = n_due - 2 * self.buffer_size
                if self.ir_format is IRFormat.FULL:
                    skip -= skip % 2  # keep the 0x3E/0x3F alternation
                self._k += skip
                self.stats.overflowed += skip
                self._pending_full = None
                n_due -= skip
            for _ in range(max(n_due, 0)):
                self._emit(self._t0 + self._k * REPORT_PERIOD_S)
                self._k += 1
        while self._pending and self._pending[0][0] <= now + EPS:
            _, _, report = heapq.heappop(self._pending)
            if len(self._buffer) >= self.buffer_size:
                self._buffer.popleft()
                self.stats.overflowed += 1
            self._buffer.append(report)

    # ---------------------------------------------------------------- output reports

    def _ack(self, now: float, report_id: int, error: int) -> None:
        if self.faults.lost_acks > 0:
            self.faults.lost_acks -= 1
            self.stats.lost_acks += 1
            return
        self.stats.acks += 1
        self._respond(now, encode_ack(report_id, error, buttons=self._buttons(now)))

    def _handle_output(self, now: float, data: bytes) -> None:
        rid = data[0]
        expected = OUTPUT_LENGTHS.get(rid)
        if expected is None:
            self._ack(now, rid, ERR_MALFORMED)  # an id the remote does not know
            return
        if len(data) != expected:
            self._ack(now, rid, ERR_MALFORMED)
            return
        flags = data[1]
        self.rumble = bool(flags & FLAG_RUMBLE)
        wants_ack = bool(flags & FLAG_ACK)

        if rid == OUT_WRITE:
            self._ack(now, rid, self._handle_write(data))
            return
        if rid == OUT_READ:
            self._handle_read(now, data)
            return
        if rid == OUT_STATUS_REQUEST:
            self.stats.status_replies += 1
            self._respond(now, self._status_report())
            return
        if rid == OUT_LEDS:
            self.leds = flags & STATUS_LED_MASK
        elif rid == OUT_REPORT_MODE:
            self.continuous = bool(flags & FLAG_CONTINUOUS)
            mode = data[2]
            if mode in INPUT_LENGTHS and mode >= IN_BUTTONS:
                self.report_mode = mode
                self._awaiting_mode = False
            else:
                self.report_mode = None
        elif rid == OUT_IR_PIXEL_CLOCK:
            self.pixel_clock = bool(flags & IR_ENABLE)
        elif rid == OUT_IR_LOGIC:
            self.ir_logic = bool(flags & IR_ENABLE)
        if rid in (OUT_IR_PIXEL_CLOCK, OUT_IR_LOGIC) and not (self.pixel_clock and self.ir_logic):
            self.camera_running = False  # power to the camera is cut
            self._cfg_written = None
        if wants_ack:
            self._ack(now, rid, ERR_OK)

    def _status_report(self) -> bytes:
        flags = self.leds
        if self.pixel_clock and self.ir_logic:
            flags |= STATUS_IR
        if self.battery < 0x20:
            flags |= STATUS_BATTERY_LOW
        return encode_status(self._buttons(self.clock.now()), flags, self.battery)

    # 0x16: [SS, A2, A1, A0, size, 16 data bytes]
    def _handle_write(self, data: bytes) -> int:
        self.stats.writes += 1
        space, address, size = data[1], data[2] << 16 | data[3] << 8 | data[4], data[5]
        if not 1 <= size <= 16:
            return ERR_MALFORMED
        payload = data[6 : 6 + size]
        if space & SPACE_REGISTER:
            if not all(self._reg_exists(address + i) for i in range(size)):
                return ERR_BAD_ADDRESS
            for i, b in enumerate(payload):
                self._reg_write(address + i, b)
        else:
            if address + size > EEPROM_SIZE:
                return ERR_BAD_ADDRESS
            self.eeprom[address : address + size] = payload
        return ERR_OK

    # 0x17: [SS, A2, A1, A0, size_hi, size_lo] -> 0x21 replies of up to 16 bytes
    def _handle_read(self, now: float, data: bytes) -> None:
        space, address, size = data[1], data[2] << 16 | data[3] << 8 | data[4], data[5] << 8 | data[6]
        buttons = self._buttons(now)
        if size == 0:
            self._ack(now, OUT_READ, ERR_MALFORMED)
            return
        if space & SPACE_REGISTER:
            if address >> 16 == 0xA4 or address >> 16 == 0xA6:  # no extension plugged in
                self._respond(now, encode_read_reply(address, b"", error=READ_ERR_WRITE_ONLY, buttons=buttons))
                self.stats.read_replies += 1
                return
            if not all(self._reg_exists(address + i) for i in range(size)):
                self._respond(now, encode_read_reply(address, b"", error=READ_ERR_NO_MEMORY, buttons=buttons))
                self.stats.read_replies += 1
                return
            content = bytes(self._reg_read(address + i) or 0 for i in range(size))
        else:
            if address + size > EEPROM_SIZE:
                self._respond(now, encode_read_reply(address, b"", error=READ_ERR_NO_MEMORY, buttons=buttons))
                self.stats.read_replies += 1
                return
            content = bytes(self.eeprom[address : address + size])
        for off in range(0, size, 16):
            self._respond(now, encode_read_reply(address + off, content[off : off + 16], buttons=buttons))
            self.stats.read_replies += 1

    @staticmethod
    def _reg_exists(address: int) -> bool:
        return IR_REGION_START <= address < IR_REGION_END or (address >> 16) in REGISTER_SPACES

    def _reg_read(self, address: int) -> int | None:
        if IR_REGION_START <= address < IR_REGION_END:
            return self.ir_registers[address & 0xFF]
        return self.other_registers.get(address, 0)

    def _reg_write(self, address: int, value: int) -> None:
        if not IR_REGION_START <= address < IR_REGION_END:
            self.other_registers[address] = value
            return
        canonical = IR_REGION_START | (address & 0xFF)
        self.ir_registers[address & 0xFF] = value
        if not (self.pixel_clock and self.ir_logic):
            return  # an unpowered camera ignores its bus
        if canonical == IR_REG_CONTROL:
            if value == IR_CONTROL_CONFIGURE:
                self._cfg_written = set()
                self.camera_running = False
            elif value == IR_CONTROL_RUN:
                complete = self._cfg_written is not None and self._cfg_written >= _CONFIG_ADDRESSES
                self._cfg_written = None
                if not complete:
                    self.camera_running = False
                    return
                self.stats.starts += 1
                if self._dead_remaining > 0:  # "IR camera on but not taking data"
                    self._dead_remaining -= 1
                    self.stats.starts_ignored += 1
                    self.camera_running = False
                else:
                    self.camera_running = True
        elif self._cfg_written is not None:
            self._cfg_written.add(canonical)

    # ---------------------------------------------------------------- the stream

    @property
    def ir_format(self) -> IRFormat | None:
        """The camera's format from its mode byte (None for an invalid byte)."""
        try:
            return IRFormat(self.ir_mode_byte)
        except ValueError:
            return None

    def _stream_ok(self) -> bool:
        if not (self._open and self.camera_running and self.pixel_clock and self.ir_logic):
            return False
        if self._awaiting_mode or self.report_mode is None:
            return False
        fmt = self.ir_format
        return fmt is not None and self.report_mode in REPORT_MODES[fmt]

    def _update_stream(self, now: float) -> None:
        ok = self._stream_ok()
        if ok and not self._streaming:
            self._streaming = True
            self._stream_id += 1
            self._t0, self._k = now + self.phase_s, 0
            self._slot_sources = [None] * 4
            self._pending_full = None
        elif not ok:
            self._streaming = False

    @property
    def blind(self) -> bool:
        """True when the sensitivity's gain limit is not below its gain: the camera sees nothing."""
        return self.ir_registers[0x1A] >= self.ir_registers[0x08]

    def _buttons(self, t: float) -> int:
        return int(self.buttons_fn(t)) if self.buttons_fn is not None else 0

    def _observe(self, t: float) -> _Frame:
        """One camera frame at time t: track blobs into slots (a blob keeps its slot, a new blob
        takes the lowest free one)."""
        pts = np.asarray(self.sources(t), dtype=float).reshape(-1, 3)
        frame = _Frame()
        if pts.shape[0] == 0 or self.blind:
            self._slot_sources = [None] * 4
            return frame
        uv = self.camera.observe(pts, self.rng, sigma_px=self.sigma_px, dropout=self.dot_dropout, max_blobs=None)
        sizes = self.camera.blob_sizes(pts)
        visible = np.isfinite(uv).all(axis=1)
        with np.errstate(invalid="ignore"):
            visible &= uv[:, 0] != MISSING  # x = 1023 reads as "missing" on the wire
            visible &= ~((uv[:, 0] == 0) & (uv[:, 1] == 0))  # so does (0, 0)
        for s, src in enumerate(self._slot_sources):
            if src is not None and (src >= len(visible) or not visible[src]):
                self._slot_sources[s] = None
        tracked = {src for src in self._slot_sources if src is not None}
        for src in np.flatnonzero(visible):
            if int(src) in tracked:
                continue
            if None not in self._slot_sources:
                break
            s = self._slot_sources.index(None)
            self._slot_sources[s] = int(src)
            frame.new.add(s)
        for s, src in enumerate(self._slot_sources):
            if src is not None:
                frame.slots[s] = (src, int(uv[src, 0]), int(uv[src, 1]))
                frame.sizes[s] = int(np.clip(sizes[src], 0, 15))
        return frame

    @staticmethod
    def _bbox(x: int, y: int, size: int) -> BBox:
        """A blob's bounding box on the 128x96 sensor, from its centre and size."""
        cx, cy, r = x / 8.0, y / 8.0, max(0.5, size / 2.0)
        return (
            int(np.clip(math.floor(cx - r), 0, 127)),
            int(np.clip(math.floor(cy - r), 0, 95)),
            int(np.clip(math.ceil(cx + r), 0, 127)),
            int(np.clip(math.ceil(cy + r), 0, 95)),
        )

    def _encode(self, report_id: int, frame: _Frame, t: float) -> bytes:
        dots: dict[int, Dot] = {}
        sizes: dict[int, int] = {}
        bboxes: dict[int, BBox] = {}
        intensities: dict[int, int] = {}
        for s in range(4):
            if s in frame.slots:
                _, x, y = frame.slots[s]
                size = frame.sizes[s]
                if self.faults.zero_first and s in frame.new:
                    dots[s], sizes[s] = (0, 0), 0
                    continue
                dots[s], sizes[s] = (x, y), size
                bboxes[s] = self._bbox(x, y, size)
                intensities[s] = int(min(255, 40 + 24 * size))
            elif self.faults.zero_missing:
                dots[s], sizes[s] = (0, 0), 0
        return encode_ir_report(
            report_id,
            dots,
            sizes=sizes,
            bboxes=bboxes,
            intensities=intensities,
            buttons=self._buttons(t),
            accel=self.accel,
        )

    def _emit(self, t: float) -> None:
        """Produce data report k (due at t) and queue it unless it is lost."""
        fmt = self.ir_format
        mode = self.report_mode
        assert fmt is not None and mode is not None
        if fmt is IRFormat.FULL:
            if self._k % 2 == 0:
                self._pending_full = self._observe(t)
                rid, frame, carried = IN_INTERLEAVED_A, self._pending_full, (0, 1)
            else:
                frame = self._pending_full if self._pending_full is not None else self._observe(t)
                rid, carried = IN_INTERLEAVED_B, (2, 3)
        else:
            rid, frame, carried = mode, self._observe(t), (0, 1, 2, 3)
        truth = {s: v for s, v in frame.slots.items() if s in carried}
        if self.faults.zero_first:
            truth = {s: v for s, v in truth.items() if s not in frame.new}
        dropped = self.rng.random() < self.faults.drop_probability if self.faults.drop_probability > 0 else False
        self.history.append(SentReport(self._k, t, rid, truth, dropped, self._stream_id))
        if dropped:
            self.stats.dropped += 1
            return
        report = self._encode(rid, frame, t)
        if self.faults.garbage_probability > 0 and self.rng.random() < self.faults.garbage_probability:
            self._queue_data(t, self._garbage(report))
            self.stats.garbage += 1
        self._queue_data(t, report)
        self.stats.data_reports += 1

    def _queue_data(self, t: float, report: bytes) -> None:
        self._seq += 1
        heapq.heappush(self._pending, (t, self._seq, report))

    def _garbage(self, real: bytes) -> bytes:
        """A report no parser may accept: truncated, of an unknown id, or of a wrong length."""
        kind = int(self.rng.integers(0, 3))
        if kind == 0:  # truncated real report
            return real[: int(self.rng.integers(1, len(real)))]
        if kind == 1:  # unknown id, random bytes
            unknown = [i for i in range(256) if i not in INPUT_LENGTHS]
            rid = unknown[int(self.rng.integers(0, len(unknown)))]
            n = int(self.rng.integers(1, 23))
            return bytes([rid]) + self.rng.integers(0, 256, size=n - 1, dtype=np.uint8).tobytes()
        ids = sorted(INPUT_LENGTHS)  # known id, wrong length
        rid = ids[int(self.rng.integers(0, len(ids)))]
        lengths = [n for n in range(1, MAX_REPORT_LENGTH) if n != INPUT_LENGTHS[rid]]
        n = lengths[int(self.rng.integers(0, len(lengths)))]
        return bytes([rid]) + self.rng.integers(0, 256, size=n - 1, dtype=np.uint8).tobytes()

    def __repr__(self) -> str:
        return (
            f"SimulatedWiimote({self.camera.name}, open={self._open}, streaming={self._streaming}, "
            f"mode={self.report_mode and hex(self.report_mode)}, ir={self.ir_mode_byte})"
        )
