"""The Wiimote driver: start the IR camera, read its dots, survive everything the link does.

`WiimoteDriver` owns one remote's session over a `Transport` (hidapi or the simulator):

1. open the transport, set the player LEDs (0x10/0x20/0x40/0x80 for players 1-4), ask for a
   status report (battery);
2. start the IR camera in the Linux kernel's order (`output_reports.ir_start_sequence`): 0x13 <- 0x06
   and 0x1A <- 0x06 (each acknowledged), then the register writes 0xB00030 <- 0x01, sensitivity
   block 1 at 0xB00000, block 2 at 0xB0001A, the mode byte at 0xB00033, 0xB00030 <- 0x08, each
   waiting for its 0x22 acknowledgement (timeout on the injected clock, a few retries, then a
   `WiimoteError` that says what to check), then 0x12 with the continuous flag and the report
   mode that matches the format;
3. verify that IR reports arrive (a dark room has no dots, but the reports still come): if none
   arrive within `stream_timeout_s` the camera came up in a bad state and the sequence is run
   again, up to `start_attempts` times. While streaming, a gap of `stall_timeout_s` without IR
   reports restarts the camera the same way;
4. read: every report is parsed (`input_reports.parse`); a `ProtocolError` is counted
   (`stats.bad_reports`) and skipped, IR reports become `IRFrame`s (the full format's 0x3E half
   is paired with the 0x3F that follows it), an unsolicited status report makes the driver send
   its reporting mode again (the remote stops reporting after one, as the kernel driver knows);
5. a read or write error is a disconnect: state `disconnected`, a log line and the `on_state`
   callback, then reopen attempts with exponential back-off on the injected clock, the whole
   start sequence again, and the stream resumes. Nothing in the read loop can crash it.

Two ways to read, same loop:
- `poll(timeout_s)` reads everything pending, synchronously, and returns the frames. With a
  `SimClock` and a `SimulatedWiimote` this is how simulations run faster than real time: advance
  the clock, poll. `poll(0)` never advances the clock; waits (acks, a positive timeout) advance a
  `SimClock` by sleeping on it in 1 ms steps.
- `start()`/`stop()` run the loop on a background thread and deliver frames to `on_frame` or to
  the thread-safe queue `frames`. Meant for real time (`SystemClock`); with a `SimClock` the
  thread drives simulated time forward by itself.

Time stamps: `IRFrame.t` is the arrival time on the clock. The remote sends no time stamp or
counter, so `t_device` estimates when the remote sent the report: reports read together in one
batch were queued at 10 ms intervals and the newest one arrived just now. Lost reports are
counted from the same estimate (`stats.drops_detected`): exact when reports are read at least
every 10 ms, within one report otherwise.
"""

from __future__ import annotations

import contextlib
import enum
import logging
import queue
import threading
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from wiithrow.clock import Clock
from wiithrow.vision.errors import VisionError
from wiithrow.vision.wiimote.input_reports import (
    Ack,
    IRReport,
    ReadReply,
    Report,
    StatusReport,
    combine_interleaved_accel,
    parse,
)
from wiithrow.vision.wiimote.ir_dots import BBox, Dot
from wiithrow.vision.wiimote.output_reports import (
    encode_ir_logic,
    encode_ir_pixel_clock,
    encode_leds,
    encode_read,
    encode_report_mode,
    encode_status_request,
    ir_start_sequence,
)
from wiithrow.vision.wiimote.protocol import (
    DEFAULT_SENSITIVITY,
    IN_BUTTONS,
    IN_BUTTONS_ACCEL_IR10_EXT6,
    IN_INTERLEAVED_A,
    IN_INTERLEAVED_B,
    MAX_REPORT_LENGTH,
    REPORT_MODES,
    Button,
    IRFormat,
    ProtocolError,
    player_leds,
    sensitivity_blocks,
)
from wiithrow.vision.wiimote.transport import KERNEL_DRIVER_HINT, DeviceAccessError, Transport

REPORT_PERIOD_S = 0.01
READ_SIZE = MAX_REPORT_LENGTH
IDLE_STEP_S = 0.001  # how long to sleep on the clock when a read returned nothing at once
MAX_BATCH = 4096  # reports drained per poll at most (a HID buffer holds far fewer)
_NAN_DOTS = np.full((4, 2), np.nan)
_NAN_4 = np.full(4, np.nan)
_NAN_BOXES = np.full((4, 4), np.nan)


class WiimoteError(VisionError):
    """The remote does not do what the protocol says (no acknowledgement, no IR stream)."""


class DriverState(str, enum.Enum):
    CLOSED = "closed"
    CONNECTING = "connecting"
    STREAMING = "streaming"
    DISCONNECTED = "disconnected"


@dataclass(frozen=True, eq=False)
class IRFrame:
    """One camera frame as the driver decoded it.

    `dots` (4, 2) float pixels, NaN for an empty slot; `sizes` (4,) blob sizes (NaN where absent
    or in the basic format); `intensities` (4,) and `bboxes` (4, 4) (xmin, ymin, xmax, ymax on
    the 128x96 sensor) in the full format, NaN otherwise. `t` is the arrival time on the clock,
    `t_device` the estimated send time (see the module docstring), `seq` counts frames from 0 over
    the driver's life (across reconnects), `report_id` is the report that completed the frame.
    """

    t: float
    t_device: float
    seq: int
    report_id: int
    dots: NDArray[np.float64]
    sizes: NDArray[np.float64]
    buttons: Button
    accel: tuple[int, int, int] | None = None
    intensities: NDArray[np.float64] = field(default_factory=lambda: np.full(4, np.nan))
    bboxes: NDArray[np.float64] = field(default_factory=lambda: np.full((4, 4), np.nan))

    @property
    def visible(self) -> NDArray[np.bool_]:
        """Which of the four slots hold a dot."""
        return np.isfinite(self.dots).all(axis=1)


@dataclass
class DriverStats:
    """Counters of a driver's life."""

    reports: int = 0  # valid input reports read
    ir_reports: int = 0
    frames: int = 0
    bad_reports: int = 0  # ProtocolError: garbage, truncated, unknown id
    drops_detected: int = 0  # IR reports the remote sent but we never got (estimated from timing)
    incomplete_pairs: int = 0  # full format: a 0x3E or 0x3F whose other half was lost
    disconnects: int = 0
    reconnects: int = 0
    reconnect_failures: int = 0
    camera_starts: int = 0  # start sequences run
    camera_restarts: int = 0  # ... because no IR reports came
    write_retries: int = 0
    status_reports: int = 0
    unexpected_reports: int = 0  # acks/read replies nobody waited for, non-IR data reports
    queue_overflows: int = 0
    loop_errors: int = 0  # unexpected exceptions the background loop survived
    callback_errors: int = 0


TransportOrFactory = Transport | Callable[[], Transport]


class WiimoteDriver:
    """One Wiimote's IR stream over a transport (see the module docstring)."""

    def __init__(
        self,
        transport: TransportOrFactory,
        clock: Clock,
        *,
        sensitivity: str = DEFAULT_SENSITIVITY,
        ir_format: str | IRFormat = "extended",
        player_led: int = 1,
        basic_report_mode: int = IN_BUTTONS_ACCEL_IR10_EXT6,
        ack_timeout_s: float = 0.1,
        write_retries: int = 3,
        stream_timeout_s: float = 0.5,
        start_attempts: int = 4,
        stall_timeout_s: float = 0.5,
        backoff_initial_s: float = 0.1,
        backoff_max_s: float = 5.0,
        on_frame: Callable[[IRFrame], Any] | None = None,
        on_state: Callable[[DriverState, str], Any] | None = None,
        queue_size: int = 4096,
        name: str = "wiimote",
        logger: logging.Logger | None = None,
    ) -> None:
        self.ir_format = IRFormat.from_name(ir_format)
        sensitivity_blocks(sensitivity)  # validates the name
        self.sensitivity = str(sensitivity).lower()
        self.player_led = int(player_led)
        self._leds = player_leds(self.player_led)
        if self.ir_format is IRFormat.BASIC:
            if basic_report_mode not in REPORT_MODES[IRFormat.BASIC]:
                raise ProtocolError(f"basic IR comes in report 0x36 or 0x37, not {basic_report_mode:#04x}")
            self.report_mode = int(basic_report_mode)
        else:
            self.report_mode = REPORT_MODES[self.ir_format][0]
        self.start_steps = ir_start_sequence(self.sensitivity, self.ir_format, self.report_mode)

        if isinstance(transport, Transport):
            self._transport: Transport | None = transport
            self._factory: Callable[[], Transport] | None = None
        elif callable(transport):
            self._transport = None
            self._factory = transport
        else:
            raise TypeError("transport must be a Transport or a callable returning one")
        self.clock = clock
        self.ack_timeout_s = float(ack_timeout_s)
        self.write_retries = max(1, int(write_retries))
        self.stream_timeout_s = float(stream_timeout_s)
        self.start_attempts = max(1, int(start_attempts))
        self.stall_timeout_s = float(stall_timeout_s)
        self.backoff_initial_s = float(backoff_initial_s)
        self.backoff_max_s = float(backoff_max_s)
        self.on_frame = on_frame
        self.on_state = on_state
        self.name = name
        self.log = logger or logging.getLogger(f"wiithrow.vision.wiimote.{name}")
        self.frames: queue.Queue[IRFrame] = queue.Queue(maxsize=max(1, int(queue_size)))

        self.stats = DriverStats()
        self.state = DriverState.CLOSED
        self.battery: int | None = None
        self.last_error: str = ""
        self._io_lock = threading.RLock()
        self._thread: threading.Thread | None = None
        self._stop = threading.Event()
        self._ready: list[IRFrame] = []  # frames decoded while waiting for something else
        self._half: tuple[IRReport, float, float] | None = None  # pending 0x3E
        self._seq = 0
        self._streaming = False
        self._last_ir_t = 0.0
        self._backoff = self.backoff_initial_s
        self._next_attempt = 0.0
        self._seg_t0: float | None = None  # drop estimate: device time of the segment's first report
        self._seg_n = 0
        self._seg_drops = 0
        self._drops_closed = 0

    # ------------------------------------------------------------------ lifecycle

    @property
    def transport(self) -> Transport | None:
        return self._transport

    def connect(self) -> None:
        """Open the remote and start its camera; raises `WiimoteError`, `DeviceAccessError` or
        `OSError`-based `WiimoteError` when that fails (later failures are recovered from)."""
        with self._io_lock:
            self._set_state(DriverState.CONNECTING, "connecting")
            try:
                self._open_transport()
                self._setup()
            except OSError as exc:
                self._close_transport()
                self._set_state(DriverState.CLOSED, f"cannot connect: {exc}")
                raise WiimoteError(f"{self.name}: cannot talk to the remote: {exc}") from exc
            except (WiimoteError, DeviceAccessError):
                self._close_transport()
                self._set_state(DriverState.CLOSED, "cannot connect")
                raise

    def close(self) -> None:
        """Stop the thread, switch the camera off (best effort) and release the device."""
        self.stop()
        with self._io_lock:
            t = self._transport
            if t is not None and self.state is DriverState.STREAMING:
                for report in (
                    encode_report_mode(IN_BUTTONS, continuous=False),
                    encode_ir_pixel_clock(False, ack=False),
                    encode_ir_logic(False, ack=False),
                ):
                    try:
                        t.write(report)
                    except Exception:
                        break
            self._close_transport()
            self._streaming = False
            self._set_state(DriverState.CLOSED, "closed")

    def __enter__(self) -> WiimoteDriver:
        if self.state is DriverState.CLOSED:
            self.connect()
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    # ------------------------------------------------------------------ reading

    def poll(self, timeout_s: float = 0.0) -> list[IRFrame]:
        """Read every pending report and return the frames they make (oldest first).

        Waits up to `timeout_s` on the clock for the first report when none is pending.
        Connects first if needed. Not to be mixed with a running `start()` thread.
        """
        if self._thread is not None and self._thread.is_alive():
            raise RuntimeError(f"{self.name}: poll() while the background reader runs; use frames/on_frame")
        if self.state is DriverState.CLOSED:
            self.connect()
        with self._io_lock:
            return self._poll_once(timeout_s)

    def start(self, on_frame: Callable[[IRFrame], Any] | None = None) -> None:
        """Run the read loop on a background thread; frames go to `on_frame` or `frames`."""
        if on_frame is not None:
            self.on_frame = on_frame
        if self._thread is not None and self._thread.is_alive():
            return
        if self.state is DriverState.CLOSED:
            self.connect()
        self._stop.clear()
        self._thread = threading.Thread(target=self._run, name=f"wiimote-{self.name}", daemon=True)
        self._thread.start()

    def stop(self, timeout_s: float = 2.0) -> None:
        """Stop the background thread (no-op when not running)."""
        self._stop.set()
        thread, self._thread = self._thread, None
        if thread is not None and thread is not threading.current_thread():
            thread.join(timeout_s)

    @property
    def running(self) -> bool:
        return self._thread is not None and self._thread.is_alive()

    def _run(self) -> None:
        while not self._stop.is_set():
            try:
                with self._io_lock:
                    frames = self._poll_once(0.02)
                    disconnected = self.state is DriverState.DISCONNECTED
                    wait = self._next_attempt - self.clock.now()
                for frame in frames:
                    self._deliver(frame)
                if disconnected:
                    self.clock.sleep(min(max(wait, 0.001), 0.05))
            except Exception as exc:  # the loop survives anything; say what happened
                self.stats.loop_errors += 1
                self.log.exception("%s: unexpected error in the read loop: %s", self.name, exc)
                self.clock.sleep(0.01)

    def _deliver(self, frame: IRFrame) -> None:
        if self.on_frame is not None:
            try:
                self.on_frame(frame)
            except Exception:
                self.stats.callback_errors += 1
                self.log.exception("%s: on_frame callback failed", self.name)
            return
        while True:
            try:
                self.frames.put_nowait(frame)
                return
            except queue.Full:
                try:
                    self.frames.get_nowait()  # drop the oldest
                    self.stats.queue_overflows += 1
                except queue.Empty:
                    pass

    def _poll_once(self, timeout_s: float) -> list[IRFrame]:
        frames = self._take_ready()
        if self.state is DriverState.DISCONNECTED:
            if not self._try_reconnect():
                if timeout_s > 0 and self._thread is None:
                    wait = min(timeout_s, self._next_attempt - self.clock.now())
                    if wait > 0:
                        self.clock.sleep(wait)
                    if not self._try_reconnect():
                        return frames
                else:
                    return frames
            frames += self._take_ready()
        if self.state is DriverState.CLOSED:
            return frames
        try:
            batch = self._read_batch(timeout_s)
            frames += self._process_batch(batch)
            frames += self._take_ready()
            if self._streaming and self.clock.now() - self._last_ir_t > self.stall_timeout_s:
                self.log.warning(
                    "%s: no IR reports for %.2f s; restarting the camera",
                    self.name,
                    self.clock.now() - self._last_ir_t,
                )
                self.stats.camera_restarts += 1
                self._start_camera()
                frames += self._take_ready()
        except OSError as exc:
            self._disconnected(exc)
            frames += self._take_ready()
        except WiimoteError as exc:  # the remote stopped answering: treat as a lost link
            self._disconnected(exc)
            frames += self._take_ready()
        return frames

    def _take_ready(self) -> list[IRFrame]:
        ready, self._ready = self._ready, []
        return ready

    # ------------------------------------------------------------------ transport I/O

    def _open_transport(self) -> None:
        if self._factory is not None:
            self._transport = self._factory()
        assert self._transport is not None
        self._transport.open()

    def _close_transport(self) -> None:
        t = self._transport
        if t is not None:
            with contextlib.suppress(Exception):
                t.close()
        if self._factory is not None:
            self._transport = None

    def _write(self, report: bytes) -> None:
        t = self._transport
        if t is None:
            raise OSError("the remote is not open")
        n = t.write(report)  # exactly the report's length, never padded
        if n is not None and 0 <= n < len(report):
            raise OSError(f"short write of report {report[0]:#04x}: {n} of {len(report)} bytes")

    def _read_until(self, deadline: float) -> tuple[float, bytes] | None:
        """One report, waiting on the clock until `deadline`; None on timeout."""
        t = self._transport
        if t is None:
            raise OSError("the remote is not open")
        while True:
            before = self.clock.now()
            remaining = deadline - before
            data = t.read(READ_SIZE, int(max(0.0, min(remaining, 0.01)) * 1000))
            now = self.clock.now()
            if data:
                return now, bytes(data)
            if now >= deadline - 1e-12:
                return None
            if now - before < IDLE_STEP_S / 2:  # the read did not wait (simulator, 0 ms timeout)
                self.clock.sleep(min(IDLE_STEP_S, deadline - now))

    def _read_batch(self, timeout_s: float) -> list[tuple[float, bytes]]:
        first = self._read_until(self.clock.now() + max(0.0, timeout_s))
        if first is None:
            return []
        batch = [first]
        t = self._transport
        assert t is not None
        while len(batch) < MAX_BATCH:
            data = t.read(READ_SIZE, 0)
            if not data:
                break
            batch.append((self.clock.now(), bytes(data)))
        return batch

    # ------------------------------------------------------------------ decoding

    def decode(self, batch: list[tuple[float, bytes]]) -> list[IRFrame]:
        """Decode reports read back to back, given as (arrival time, bytes), into frames: the
        decoding half of the read loop, public so that recorded reports can be replayed."""
        return self._process_batch(batch)

    def _process_batch(self, batch: list[tuple[float, bytes]]) -> list[IRFrame]:
        """Parse a batch read back to back; estimate device times of its IR reports."""
        parsed: list[tuple[float, Report | None]] = []
        for t_arr, data in batch:
            try:
                parsed.append((t_arr, parse(data)))
            except ProtocolError as exc:
                self.stats.bad_reports += 1
                self.log.debug("%s: skipped a bad report: %s", self.name, exc)
        n_ir_after = sum(isinstance(r, IRReport) for _, r in parsed)
        t_end = batch[-1][0] if batch else self.clock.now()
        frames: list[IRFrame] = []
        for t_arr, rep in parsed:
            if isinstance(rep, IRReport):
                n_ir_after -= 1
                t_dev = min(t_arr, t_end - n_ir_after * REPORT_PERIOD_S)
            else:
                t_dev = t_arr
            frame = self._dispatch(rep, t_arr, t_dev)
            if frame is not None:
                frames.append(frame)
        return frames

    def _dispatch(self, rep: Report | None, t_arr: float, t_dev: float) -> IRFrame | None:
        if rep is None:
            return None
        self.stats.reports += 1
        if isinstance(rep, IRReport):
            return self._on_ir(rep, t_arr, t_dev)
        if isinstance(rep, StatusReport):
            self.stats.status_reports += 1
            self.battery = rep.battery
            if self._streaming:  # the remote stops reporting after a status report: ask again
                self._write(encode_report_mode(self.report_mode, continuous=True))
            return None
        self.stats.unexpected_reports += 1
        return None

    def _count_ir(self, t_dev: float) -> None:
        self.stats.ir_reports += 1
        if self._seg_t0 is None:
            self._seg_t0, self._seg_n = t_dev, 0
        self._seg_n += 1
        est = round((t_dev - self._seg_t0) / REPORT_PERIOD_S) + 1 - self._seg_n
        self._seg_drops = max(0, est)
        self.stats.drops_detected = self._drops_closed + self._seg_drops

    def _close_segment(self) -> None:
        self._drops_closed += self._seg_drops
        self._seg_t0, self._seg_n, self._seg_drops = None, 0, 0
        self.stats.drops_detected = self._drops_closed
        self._half = None

    def _on_ir(self, rep: IRReport, t_arr: float, t_dev: float) -> IRFrame | None:
        self._count_ir(t_dev)
        self._last_ir_t = t_arr
        if rep.report_id == IN_INTERLEAVED_A:
            if self._half is not None:
                self.stats.incomplete_pairs += 1
            self._half = (rep, t_arr, t_dev)
            return None
        if rep.report_id == IN_INTERLEAVED_B:
            half, self._half = self._half, None
            if half is None or t_dev - half[2] > 1.5 * REPORT_PERIOD_S:
                self.stats.incomplete_pairs += 1
                return None
            first = half[0]
            dots = {**first.dots, **rep.dots}
            sizes = {**first.sizes, **rep.sizes}
            bboxes = {**first.bboxes, **rep.bboxes}
            intens = {**first.intensities, **rep.intensities}
            accel = combine_interleaved_accel(first, rep)
            return self._frame(t_arr, half[2], rep.report_id, dots, sizes, rep.buttons, accel, bboxes, intens)
        sizes = rep.sizes if rep.ir_format is IRFormat.EXTENDED else {}
        return self._frame(t_arr, t_dev, rep.report_id, rep.dots, sizes, rep.buttons, rep.accel, {}, {})

    def _frame(
        self,
        t: float,
        t_dev: float,
        report_id: int,
        dots: dict[int, Dot],
        sizes: dict[int, int],
        buttons: Button,
        accel: tuple[int, int, int] | None,
        bboxes: dict[int, BBox],
        intensities: dict[int, int],
    ) -> IRFrame:
        d = _NAN_DOTS.copy()  # copying a template costs a fraction of np.full (100 Hz per remote)
        s = _NAN_4.copy()
        inten = _NAN_4.copy()
        bb = _NAN_BOXES.copy()
        for slot, (x, y) in dots.items():
            d[slot] = (x, y)
            if slot in sizes:
                s[slot] = sizes[slot]
            if slot in intensities:
                inten[slot] = intensities[slot]
            if slot in bboxes:
                bb[slot] = bboxes[slot]
        frame = IRFrame(t, t_dev, self._seq, report_id, d, s, buttons, accel, inten, bb)
        self._seq += 1
        self.stats.frames += 1
        return frame

    # ------------------------------------------------------------------ the start sequence

    def _wait(self, match: Callable[[Report], bool], timeout_s: float) -> Report | None:
        """Read until a report satisfies `match` (returned) or `timeout_s` passes (None).

        Everything read meanwhile is handled as usual (IR frames are kept for the next poll)."""
        deadline = self.clock.now() + timeout_s
        while True:
            got = self._read_until(deadline)
            if got is None:
                return None
            t_arr, data = got
            try:
                rep = parse(data)
            except ProtocolError as exc:
                self.stats.bad_reports += 1
                self.log.debug("%s: skipped a bad report: %s", self.name, exc)
                continue
            if match(rep):
                if isinstance(rep, IRReport):
                    frame = self._dispatch(rep, t_arr, t_arr)
                    if frame is not None:
                        self._ready.append(frame)
                else:
                    self.stats.reports += 1
                return rep
            frame = self._dispatch(rep, t_arr, t_arr)
            if frame is not None:
                self._ready.append(frame)

    def _send_acked(self, report: bytes, what: str) -> None:
        """Write `report` and wait for its 0x22; retry; `WiimoteError` when it never comes."""
        rid = report[0]
        last = "no acknowledgement"
        for attempt in range(self.write_retries):
            if attempt:
                self.stats.write_retries += 1
            self._write(report)
            ack = self._wait(lambda r: isinstance(r, Ack) and r.acked_report == rid, self.ack_timeout_s)
            if isinstance(ack, Ack):
                if ack.error == 0:
                    return
                last = f"error code {ack.error:#04x}"
                self.log.warning("%s: the remote answered %s with %s", self.name, what, last)
            else:
                last = f"no acknowledgement within {self.ack_timeout_s:.3f} s"
                self.log.debug("%s: %s: %s (try %d)", self.name, what, last, attempt + 1)
        raise WiimoteError(
            f"{self.name}: the remote did not accept {what} after {self.write_retries} tries ({last}). "
            f"Is it still connected? Also, {KERNEL_DRIVER_HINT}"
        )

    def _setup(self) -> None:
        """LEDs, status, camera: everything after opening the transport."""
        self._streaming = False
        self._half = None
        self._write(encode_leds(self._leds))
        self._write(encode_status_request())
        status = self._wait(lambda r: isinstance(r, StatusReport), self.ack_timeout_s)
        if isinstance(status, StatusReport):
            self.stats.status_reports += 1
            self.battery = status.battery
        self._start_camera()

    def _start_camera(self) -> None:
        """Run the start sequence until IR reports arrive (`start_attempts` times at most)."""
        self._streaming = False
        self._close_segment()
        for attempt in range(self.start_attempts):
            if attempt:
                self.stats.camera_restarts += 1
            self.stats.camera_starts += 1
            for step in self.start_steps:
                if step.expects_ack:
                    self._send_acked(step.report, step.what)
                else:
                    self._write(step.report)
            first = self._wait(lambda r: isinstance(r, IRReport), self.stream_timeout_s)
            if first is not None:
                self._streaming = True
                self._last_ir_t = self.clock.now()
                self._set_state(
                    DriverState.STREAMING,
                    f"IR camera streaming ({self.ir_format.name.lower()}, {self.sensitivity}, "
                    f"report {self.report_mode:#04x}, player LED {self.player_led})",
                )
                return
            self.log.warning(
                "%s: no IR reports within %.2f s after the start sequence (try %d of %d); restarting the camera",
                self.name,
                self.stream_timeout_s,
                attempt + 1,
                self.start_attempts,
            )
        raise WiimoteError(
            f"{self.name}: the IR camera did not start streaming after {self.start_attempts} start sequences; "
            "power-cycle the remote (remove a battery) and reconnect it"
        )

    def read_registers(self, address: int, size: int, timeout_s: float | None = None) -> bytes:
        """Read `size` bytes of register space (0x17, collecting the 0x21 replies)."""
        with self._io_lock:
            self._write(encode_read(address, size))
            out = bytearray()
            deadline_s = self.ack_timeout_s * (1 + size // 16) if timeout_s is None else timeout_s
            while len(out) < size:
                rep = self._wait(lambda r: isinstance(r, ReadReply), deadline_s)
                if not isinstance(rep, ReadReply):
                    raise WiimoteError(f"{self.name}: no reply reading {size} bytes at {address:#08x}")
                if rep.error:
                    raise WiimoteError(
                        f"{self.name}: reading {address:#08x} failed with error {rep.error} "
                        "(7: write-only or no extension, 8: no such memory)"
                    )
                out += rep.data
            return bytes(out[:size])

    # ------------------------------------------------------------------ disconnects

    def _set_state(self, state: DriverState, message: str) -> None:
        changed = state is not self.state
        self.state = state
        if changed:
            self.log.info("%s: %s: %s", self.name, state.value, message)
            if self.on_state is not None:
                try:
                    self.on_state(state, message)
                except Exception:
                    self.stats.callback_errors += 1
                    self.log.exception("%s: on_state callback failed", self.name)

    def _disconnected(self, exc: BaseException) -> None:
        self.stats.disconnects += 1
        self.last_error = str(exc)
        self._streaming = False
        self._close_segment()
        self._close_transport()
        self._backoff = self.backoff_initial_s
        self._next_attempt = self.clock.now() + self._backoff
        self.log.warning("%s: lost the remote (%s); reconnecting with back-off", self.name, exc)
        self._set_state(DriverState.DISCONNECTED, f"lost the remote: {exc}")

    def _try_reconnect(self) -> bool:
        if self.clock.now() < self._next_attempt:
            return False
        try:
            self._open_transport()
            self._setup()
        except (OSError, WiimoteError, DeviceAccessError) as exc:
            self.stats.reconnect_failures += 1
            self.last_error = str(exc)
            self._close_transport()
            self._streaming = False
            self._backoff = min(self._backoff * 2.0, self.backoff_max_s)
            self._next_attempt = self.clock.now() + self._backoff
            self.log.debug("%s: reconnect failed (%s); next try in %.2f s", self.name, exc, self._backoff)
            if self.state is not DriverState.DISCONNECTED:
                self._set_state(DriverState.DISCONNECTED, f"reconnect failed: {exc}")
            return False
        self.stats.reconnects += 1
        self._backoff = self.backoff_initial_s
        self.log.info("%s: reconnected", self.name)
        return True
