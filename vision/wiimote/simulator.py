"""A simulated Wiimote that speaks the real remote's HID protocol, byte for byte.

`SimulatedWiimote` is a `Transport`: the driver writes output reports to it and reads input
reports from it exactly as from hidapi. It owns the remote's side of the link, its output-report
handling and its faults; its memory is a `RemoteMemory` (`sim_memory`: registers, EEPROM, the IR
camera's configure/run protocol) and what its data reports carry comes from a `SimulatedCamera`
(`sim_reports`: blobs tracked into slots, the report bytes). The remote:

- answers every 0x16 write with 0x22 `BB BB 16 EE` (EE 0 on success, 0x03 for a malformed write,
  0x08 for an address that does not exist) and 0x17 reads with 0x21 replies (16-byte chunks); any
  other output report whose first payload byte has the 0x02 bit set is acknowledged too (that is
  why the kernel enables the camera with 0x06 rather than 0x04), except 0x15 and 0x17, which are
  answered with their reports; a malformed or unknown output report is answered with error 0x03
  (the real remote's error codes are not documented: these are the simulator's choice);
- answers 0x15 with 0x20 `BB BB LF 00 00 VV` (LF: LED bits, 0x08 while the camera's pixel clock
  and logic are enabled, 0x01 when the battery is low);
- keeps the player LEDs, rumble and the reporting mode;
- streams NOTHING until its camera has been started with the complete sequence (0x13 and 0x1A
  enabled, the configuration written, `sim_memory`) and a reporting mode (0x12) whose IR format
  matches the mode byte (basic 1 -> 0x36/0x37, extended 3 -> 0x33, full 5 -> 0x3E). A mismatch,
  an unknown mode byte or a missing step leaves the camera silent, as real ones are.

Streaming: report k of a stream is due at t0 + k * 0.01 s on the injected clock (t0 = when the
stream started plus `phase_s`: two remotes are not synchronised, their report clocks have
arbitrary phases). `read()` returns the oldest due report; with a `SimClock` it never blocks (b""
when nothing is due); with `realtime=True` it waits up to its timeout for the next due report
(for the demo on a `SystemClock`); `read_all()` returns every due report at once and
`next_report_due()` says when the next one can be (what `link.DueReports` uses: a simulated
clock's reader need not read before then). Reports the caller does not read pile up in a bounded buffer
(`buffer_size`, default 64 like Linux hidraw), the oldest dropped first (as hidapi's libusb
backend does). In the full format the remote alternates 0x3E (slots 0-1) and 0x3F (slots 2-3)
at 100 reports per second, both halves of one camera frame: complete frames arrive at 50 Hz.

Faults for tests (`SimFaults`, and methods): a camera that comes up dead (ignores the first
`dead_starts` start sequences: "on but not taking data"), dropped reports (probability), (0, 0)
dots (for missing slots and/or a new blob's first report), lost acknowledgements, a camera that
stalls mid-stream (`stall_at`), garbage reports (random bytes, unknown ids, truncated reports)
mixed into the stream, unsolicited status reports (after which the remote stops reporting until
0x12 is sent again, per WiiBrew), and disconnects: `read`/`write` raise `OSError` as hidapi does
when the device vanishes, `open` fails until the remote is back, and it comes back power-cycled
(registers cleared, camera off). `history` records what each sent data report carried (slot ->
source index and pixel) so tests can compare decoded dots with the truth.
"""

from __future__ import annotations

import math
import threading
from collections import deque
from collections.abc import Callable
from dataclasses import replace

import numpy as np

from wiithrow.clock import Clock
from wiithrow.vision.camera import WiimoteCamera
from wiithrow.vision.wiimote import protocol
from wiithrow.vision.wiimote.input_reports import encode_ack, encode_read_reply, encode_status
from wiithrow.vision.wiimote.sim_buffer import EPS, HidBuffer
from wiithrow.vision.wiimote.sim_faults import SentReport, SimFaults, SimStats
from wiithrow.vision.wiimote.sim_memory import ERR_MALFORMED, ERR_OK, RemoteMemory
from wiithrow.vision.wiimote.sim_reports import CameraFrame, SimulatedCamera, Sources, encode_frame, garbage_report

REPORT_PERIOD_S = 0.01  # 100 reports per second
HID_BUFFER_SIZE = 64
#: A frozen dataclass's instance with no fields yet: `_emit` sets a `SentReport`'s in one
#: dictionary update, where its `__init__` calls `object.__setattr__` once per field
#: (`test_simulator` compares the two).
_new = object.__new__


class SimulatedWiimote:
    """A Wiimote at the HID-report level (see the module docstring); a `Transport`."""

    def __init__(
        self,
        camera: WiimoteCamera,
        sources: Sources,
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
        product_id: int = protocol.PRODUCT_WIIMOTE,
        buttons: Callable[[float], int] | None = None,
        accel: tuple[int, int, int] = (512, 512, 616),
        faults: SimFaults | None = None,
        history_size: int = 100_000,
    ) -> None:
        self.camera = camera
        self.clock = clock
        self.rng = rng
        self.ir_camera = SimulatedCamera(camera, sources, rng, sigma_px=sigma_px, dot_dropout=dot_dropout)
        self.realtime = bool(realtime)
        self._hid = HidBuffer(buffer_size)
        self.response_latency_s = float(response_latency_s)
        if not 0.0 <= phase_s < REPORT_PERIOD_S:
            raise ValueError(f"phase_s must lie in [0, {REPORT_PERIOD_S}) s, got {phase_s}")
        self.phase_s = float(phase_s)
        self.battery = int(battery) & 0xFF
        self.product_id = int(product_id)
        self.buttons_fn = buttons
        self.accel = (int(accel[0]), int(accel[1]), int(accel[2]))
        self.faults = replace(faults) if faults is not None else SimFaults()  # a copy: faults get used up
        self.stats = SimStats()
        self.history: deque[SentReport] = deque(maxlen=history_size)
        self.writes_log: list[bytes] = []  # every output report received, in order

        self._lock = threading.RLock()
        self._open = False
        self._vanished = False
        self._back_at: float | None = None
        self._dead_remaining = int(self.faults.dead_starts)
        self.memory = RemoteMemory(self._camera_comes_up)
        self._stream_id = 0
        self._power_on()

    # ---------------------------------------------------------------- state of the remote

    def _power_on(self) -> None:
        """The state of a freshly connected remote."""
        self.memory.power_on()
        self.leds = 0
        self.rumble = False
        self.report_mode: int | None = None  # None: the power-on 0x30 (buttons on change only)
        self.continuous = False
        self.pixel_clock = False
        self.ir_logic = False
        self._awaiting_mode = False
        self._streaming = False
        self._t0 = 0.0
        self._k = 0
        self.ir_camera.reset()
        self._pending_full: CameraFrame | None = None
        self._hid.clear()

    @property
    def sensitivity(self) -> str | None:
        """The named sensitivity whose blocks are in the registers (None if custom or unset)."""
        return self.memory.sensitivity

    @property
    def camera_running(self) -> bool:
        """Whether the IR camera takes data (configured, started and powered)."""
        return self.memory.camera_running

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
        return self.memory.register(address, size)

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
            self.memory.camera_running = False  # "on but not taking data" until the next start sequence
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
                self._hid.clear()  # nothing was buffered for a closed handle
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

    def read(self, max_size: int = protocol.MAX_REPORT_LENGTH, timeout_ms: int = 0) -> bytes:
        deadline: float | None = None
        while True:  # in real-time mode, wait (without the lock) for the next due report
            with self._lock:
                now = self.clock.now()
                self._alive(now, "read")
                self._catch_up(now)
                report = self._hid.pop()
                if report is not None:
                    return report[: max(0, int(max_size))]
                if deadline is None:
                    if not self.realtime or timeout_ms <= 0:
                        return b""
                    deadline = now + timeout_ms / 1000.0
                if now >= deadline - EPS:
                    return b""
                wake = min(deadline, self._next_due())
            self.clock.sleep(max(wake - now, 0.0005))

    def read_all(self, max_size: int = protocol.MAX_REPORT_LENGTH) -> list[bytes]:
        """Every report due now, oldest first, at once (`read(max_size, 0)` until b"", in one call:
        a batch read after a simulated clock's step usually finds one or two)."""
        with self._lock:
            now = self.clock.now()
            self._alive(now, "read")
            self._catch_up(now)
            out = self._hid.pop_all()
        n = max(0, int(max_size))
        return out if max(map(len, out), default=0) <= n else [r[:n] for r in out]

    def next_report_due(self) -> float:
        """The earliest clock time a read can return a report or a scheduled fault can fire: -inf
        when one is waiting already or a read would raise (closed, vanished); inf when nothing is
        scheduled. Before then a read returns b"" and changes nothing, so a reader on a simulated
        clock need not read (`link.RemoteLink.nothing_due`)."""
        with self._lock:
            if self._hid.buffered or not self._open or self._vanished:
                return -math.inf
            return self._next_due()

    def _alive(self, now: float, what: str) -> None:
        self._check_schedule(now)
        if self._vanished:
            raise OSError(f"{what} error: the remote has disconnected")
        if not self._open:
            raise OSError(f"{what} error: the device is not open")

    def _next_due(self) -> float:
        t = self._hid.next_due()
        if self._streaming:
            t = min(t, self._t0 + self._k * REPORT_PERIOD_S)
        faults = self.faults
        if faults.disconnect_at is not None:
            t = min(t, faults.disconnect_at)
        if faults.stall_at is not None:
            t = min(t, faults.stall_at)
        return t

    # ---------------------------------------------------------------- the HID buffer

    def _respond(self, now: float, report: bytes) -> None:
        """Queue an immediate reply (ack, status, read data) after the configured latency."""
        self._hid.schedule(now + self.response_latency_s, report)

    def _catch_up(self, now: float) -> None:
        """Produce every data report due by `now` and move due reports into the HID buffer."""
        if self._streaming:
            n_due = math.floor((now - self._t0) / REPORT_PERIOD_S + EPS) + 1 - self._k
            if n_due > 2 * self._hid.size:  # the caller was away: these would overflow anyway
                skip = n_due - 2 * self._hid.size
                if self.memory.ir_format is protocol.IRFormat.FULL:
                    skip -= skip % 2  # keep the 0x3E/0x3F alternation
                self._k += skip
                self.stats.overflowed += skip
                self._pending_full = None
                n_due -= skip
            for _ in range(max(n_due, 0)):
                self._emit(self._t0 + self._k * REPORT_PERIOD_S)
                self._k += 1
        self.stats.overflowed += self._hid.deliver(now)

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
        expected = protocol.OUTPUT_LENGTHS.get(rid)
        if expected is None:
            self._ack(now, rid, ERR_MALFORMED)  # an id the remote does not know
            return
        if len(data) != expected:
            self._ack(now, rid, ERR_MALFORMED)
            return
        flags = data[1]
        self.rumble = bool(flags & protocol.FLAG_RUMBLE)
        wants_ack = bool(flags & protocol.FLAG_ACK)

        if rid == protocol.OUT_WRITE:
            self._ack(now, rid, self._handle_write(data))
            return
        if rid == protocol.OUT_READ:
            self._handle_read(now, data)
            return
        if rid == protocol.OUT_STATUS_REQUEST:
            self.stats.status_replies += 1
            self._respond(now, self._status_report())
            return
        if rid == protocol.OUT_LEDS:
            self.leds = flags & protocol.STATUS_LED_MASK
        elif rid == protocol.OUT_REPORT_MODE:
            self.continuous = bool(flags & protocol.FLAG_CONTINUOUS)
            mode = data[2]
            if mode in protocol.INPUT_LENGTHS and mode >= protocol.IN_BUTTONS:
                self.report_mode = mode
                self._awaiting_mode = False
            else:
                self.report_mode = None
        elif rid == protocol.OUT_IR_PIXEL_CLOCK:
            self.pixel_clock = bool(flags & protocol.IR_ENABLE)
        elif rid == protocol.OUT_IR_LOGIC:
            self.ir_logic = bool(flags & protocol.IR_ENABLE)
        if rid in (protocol.OUT_IR_PIXEL_CLOCK, protocol.OUT_IR_LOGIC):
            self.memory.set_power(self.pixel_clock and self.ir_logic)
        if wants_ack:
            self._ack(now, rid, ERR_OK)

    def _status_report(self) -> bytes:
        flags = self.leds
        if self.pixel_clock and self.ir_logic:
            flags |= protocol.STATUS_IR
        if self.battery < 0x20:
            flags |= protocol.STATUS_BATTERY_LOW
        return encode_status(self._buttons(self.clock.now()), flags, self.battery)

    # 0x16: [SS, A2, A1, A0, size, 16 data bytes]
    def _handle_write(self, data: bytes) -> int:
        self.stats.writes += 1
        space, address, size = data[1], data[2] << 16 | data[3] << 8 | data[4], data[5]
        if not 1 <= size <= 16:
            return ERR_MALFORMED
        return self.memory.write(space, address, data[6 : 6 + size])

    # 0x17: [SS, A2, A1, A0, size_hi, size_lo] -> 0x21 replies of up to 16 bytes
    def _handle_read(self, now: float, data: bytes) -> None:
        space, address, size = data[1], data[2] << 16 | data[3] << 8 | data[4], data[5] << 8 | data[6]
        buttons = self._buttons(now)
        if size == 0:
            self._ack(now, protocol.OUT_READ, ERR_MALFORMED)
            return
        error, content = self.memory.read(space, address, size)
        if error:
            self._respond(now, encode_read_reply(address, b"", error=error, buttons=buttons))
            self.stats.read_replies += 1
            return
        for off in range(0, size, 16):
            self._respond(now, encode_read_reply(address + off, content[off : off + 16], buttons=buttons))
            self.stats.read_replies += 1

    def _camera_comes_up(self) -> bool:
        """A complete start sequence ran (`RemoteMemory.on_start`): the camera comes up unless the
        dead-camera fault has starts left to ignore."""
        self.stats.starts += 1
        if self._dead_remaining > 0:  # "IR camera on but not taking data"
            self._dead_remaining -= 1
            self.stats.starts_ignored += 1
            return False
        return True

    # ---------------------------------------------------------------- the stream

    def _stream_ok(self) -> bool:
        if not (self._open and self.camera_running and self.pixel_clock and self.ir_logic):
            return False
        if self._awaiting_mode or self.report_mode is None:
            return False
        fmt = self.memory.ir_format
        return fmt is not None and self.report_mode in protocol.REPORT_MODES[fmt]

    def _update_stream(self, now: float) -> None:
        ok = self._stream_ok()
        if ok and not self._streaming:
            self._streaming = True
            self._stream_id += 1
            self._t0, self._k = now + self.phase_s, 0
            self.ir_camera.reset()
            self._pending_full = None
        elif not ok:
            self._streaming = False

    def _buttons(self, t: float) -> int:
        return int(self.buttons_fn(t)) if self.buttons_fn is not None else 0

    def _observe(self, t: float) -> CameraFrame:
        return self.ir_camera.observe(t, blind=self.memory.blind)

    def _encode(self, report_id: int, frame: CameraFrame, t: float) -> bytes:
        f = self.faults
        return encode_frame(
            report_id,
            frame,
            buttons=self._buttons(t),
            accel=self.accel,
            zero_missing=f.zero_missing,
            zero_first=f.zero_first,
        )

    def _emit(self, t: float) -> None:
        """Produce data report k (due at t) and queue it unless it is lost."""
        fmt = self.memory.ir_format
        mode = self.report_mode
        assert fmt is not None and mode is not None
        carried: tuple[int, ...]  # the slots this report carries (): all four
        if fmt is protocol.IRFormat.FULL:
            if self._k % 2 == 0:
                self._pending_full = self._observe(t)
                rid, frame, carried = protocol.IN_INTERLEAVED_A, self._pending_full, (0, 1)
            else:
                frame = self._pending_full if self._pending_full is not None else self._observe(t)
                rid, carried = protocol.IN_INTERLEAVED_B, (2, 3)
        else:
            rid, frame, carried = mode, self._observe(t), ()
        # (a report that carries every slot carries all the frame holds: a copy, no filter)
        truth = {s: v for s, v in frame.slots.items() if s in carried} if carried else frame.slots.copy()
        if self.faults.zero_first:
            truth = {s: v for s, v in truth.items() if s not in frame.new}
        dropped = self.rng.random() < self.faults.drop_probability if self.faults.drop_probability > 0 else False
        sent = _new(SentReport)  # `SentReport(k, t, ...)`, its fields set at once (`_new`)
        sent.__dict__.update(k=self._k, t=t, report_id=rid, slots=truth, dropped=dropped, stream=self._stream_id)
        self.history.append(sent)
        if dropped:
            self.stats.dropped += 1
            return
        report = self._encode(rid, frame, t)
        if self.faults.garbage_probability > 0 and self.rng.random() < self.faults.garbage_probability:
            self._hid.schedule(t, garbage_report(report, self.rng))
            self.stats.garbage += 1
        self._hid.schedule(t, report)
        self.stats.data_reports += 1

    def __repr__(self) -> str:
        return (
            f"SimulatedWiimote({self.camera.name}, open={self._open}, streaming={self._streaming}, "
            f"mode={self.report_mode and hex(self.report_mode)}, ir={self.memory.ir_mode_byte})"
        )
