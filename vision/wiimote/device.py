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
  `SimClock` by sleeping on it in 1 ms steps. A `poll(0)` that can read nothing and do nothing
  returns at once when the remote can say so (a simulated one: `link.DueReports`).
- `start()`/`stop()` run the loop on a background thread and deliver frames to `on_frame` or to
  the thread-safe queue `frames`. Meant for real time (`SystemClock`); with a `SimClock` the
  thread drives simulated time forward by itself.

`subscribe_reports(listener)` shows every input report read, as (arrival time, bytes), to as
many listeners as subscribe, in the units the driver decodes them (a batch read back to back, or
one report read while waiting for an acknowledgement), before decoding: what a recording keeps,
and a replay decodes again with the same `ReportDecoder`.

The options are a `DriverSettings` (`driver_settings`); the waits and reads on the clock are the
`RemoteLink`'s (`link`); bytes -> frames is the `ReportDecoder`'s (`decoder`: parsing, the frames,
their time stamps and the count of lost reports), which this driver feeds and answers (a status
report asks for the reporting mode again).
"""

from __future__ import annotations

import logging
import math
import queue
import threading
from collections.abc import Callable
from typing import Any

from wiithrow.clock import Clock
from wiithrow.listeners import Unsubscribe
from wiithrow.vision.wiimote.decoder import Batch, ReportDecoder
from wiithrow.vision.wiimote.driver_settings import DriverSettings, DriverState, DriverStats, WiimoteError
from wiithrow.vision.wiimote.frames import IRFrame
from wiithrow.vision.wiimote.input_reports import (
    Ack,
    IRReport,
    ReadReply,
    Report,
    StatusReport,
)
from wiithrow.vision.wiimote.link import RemoteLink, TransportOrFactory
from wiithrow.vision.wiimote.output_reports import (
    encode_ir_logic,
    encode_ir_pixel_clock,
    encode_leds,
    encode_read,
    encode_report_mode,
    encode_status_request,
)
from wiithrow.vision.wiimote.protocol import IN_BUTTONS
from wiithrow.vision.wiimote.transport import KERNEL_DRIVER_HINT, DeviceAccessError, Transport


class WiimoteDriver:
    """One Wiimote's IR stream over a transport (see the module docstring)."""

    def __init__(
        self,
        transport: TransportOrFactory,
        clock: Clock,
        settings: DriverSettings | None = None,
        *,
        name: str = "wiimote",
        on_frame: Callable[[IRFrame], object] | None = None,
        on_state: Callable[[DriverState, str], object] | None = None,
        logger: logging.Logger | None = None,
    ) -> None:
        self.settings = settings if settings is not None else DriverSettings()
        self.start_steps = self.settings.start_steps()
        self._link = RemoteLink(transport, clock)
        self.clock = clock
        self.on_frame = on_frame
        self.on_state = on_state
        self.name = name
        self.log = logger or logging.getLogger(f"wiithrow.vision.wiimote.{name}")
        self.frames: queue.Queue[IRFrame] = queue.Queue(maxsize=self.settings.queue_size)

        self.stats = DriverStats()
        self.decoder = ReportDecoder(self.stats, name=name, logger=self.log)
        self.state = DriverState.CLOSED
        self.last_error: str = ""
        self._io_lock = threading.RLock()
        self._thread: threading.Thread | None = None
        self._stop = threading.Event()
        self._ready: list[IRFrame] = []  # frames decoded while waiting for something else
        self._streaming = False
        self._backoff = self.settings.backoff_initial_s
        self._next_attempt = 0.0

    # ------------------------------------------------------------------ lifecycle

    @property
    def transport(self) -> Transport | None:
        return self._link.transport

    @property
    def battery(self) -> int | None:
        """The battery level of the last status report (None before one)."""
        return self.decoder.battery

    def subscribe_reports(self, listener: Callable[[Batch], object]) -> Unsubscribe:
        """Show every input report read (see the module docstring) to `listener`; the handle
        removes it. Its failure is counted (`stats.callback_errors`), never raised."""
        return self.decoder.subscribe(listener)

    def connect(self) -> None:
        """Open the remote and start its camera; raises `WiimoteError`, `DeviceAccessError` or
        `OSError`-based `WiimoteError` when that fails (later failures are recovered from)."""
        with self._io_lock:
            self._set_state(DriverState.CONNECTING, "connecting")
            try:
                self._link.open()
                self._setup()
            except OSError as exc:
                self._link.close()
                self._set_state(DriverState.CLOSED, f"cannot connect: {exc}")
                raise WiimoteError(f"{self.name}: cannot talk to the remote: {exc}") from exc
            except (WiimoteError, DeviceAccessError):
                self._link.close()
                self._set_state(DriverState.CLOSED, "cannot connect")
                raise

    def close(self) -> None:
        """Stop the thread, switch the camera off (best effort) and release the device."""
        self.stop()
        with self._io_lock:
            t = self._link.transport
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
            self._link.close()
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
        if timeout_s <= 0 and self._nothing_to_do():
            return []
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
            batch = self._link.read_batch(timeout_s)
            frames += self._process_batch(batch)
            frames += self._take_ready()
            if self._streaming and self.clock.now() - self.decoder.last_ir_t > self.settings.stall_timeout_s:
                self.log.warning(
                    "%s: no IR reports for %.2f s; restarting the camera",
                    self.name,
                    self.clock.now() - self.decoder.last_ir_t,
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

    def _nothing_to_do(self) -> bool:
        """A poll now would read nothing and do nothing: streaming, no frame kept, no status to
        answer, no stall to detect, and the transport says no report can be due yet (only a
        simulated remote can say so: `RemoteLink.nothing_due`)."""
        if not self._streaming or self._ready or self.decoder.status_seen or self.state is not DriverState.STREAMING:
            return False
        now = self.clock.now()
        return now - self.decoder.last_ir_t <= self.settings.stall_timeout_s and self._link.nothing_due(now)

    def quiet_until(self) -> float:
        """A clock time before which `poll()` reads nothing and changes nothing (`_nothing_to_do`
        holds until then, a nanosecond early for the stall test's round-off); -inf when a poll
        may do something now or the remote cannot tell (real devices)."""
        if self._thread is not None or not self._streaming or self._ready or self.decoder.status_seen:
            return -math.inf
        if self.state is not DriverState.STREAMING:
            return -math.inf
        return min(self.decoder.last_ir_t + self.settings.stall_timeout_s - 1e-9, self._link.quiet_until())

    def _take_ready(self) -> list[IRFrame]:
        ready, self._ready = self._ready, []
        return ready

    # ------------------------------------------------------------------ decoding

    def _process_batch(self, batch: Batch) -> list[IRFrame]:
        """Decode a batch read back to back (`ReportDecoder`), then answer a status report."""
        frames = self.decoder.decode(batch)
        self._answer_status()
        return frames

    def _answer_status(self) -> None:
        """The remote stops reporting after a status report: ask for the reporting mode again."""
        if self.decoder.status_seen:
            self.decoder.status_seen = False
            if self._streaming:
                self._link.write(encode_report_mode(self.settings.report_mode, continuous=True))

    # ------------------------------------------------------------------ the start sequence

    def _wait(self, match: Callable[[Report], bool], timeout_s: float) -> Report | None:
        """Read until a report satisfies `match` (returned) or `timeout_s` passes (None).

        Everything read meanwhile is handled as usual (IR frames are kept for the next poll)."""
        deadline = self.clock.now() + timeout_s
        while True:
            got = self._link.read_until(deadline)
            if got is None:
                return None
            t_arr, data = got
            self.decoder.show([got])
            rep = self.decoder.parse(data)
            if rep is None:
                continue
            if match(rep):
                if isinstance(rep, IRReport):
                    frame = self.decoder.dispatch(rep, t_arr, t_arr)
                    if frame is not None:
                        self._ready.append(frame)
                else:
                    self.stats.reports += 1
                return rep
            frame = self.decoder.dispatch(rep, t_arr, t_arr)
            self._answer_status()
            if frame is not None:
                self._ready.append(frame)

    def _send_acked(self, report: bytes, what: str) -> None:
        """Write `report` and wait for its 0x22; retry; `WiimoteError` when it never comes."""
        rid = report[0]
        last = "no acknowledgement"
        for attempt in range(self.settings.write_retries):
            if attempt:
                self.stats.write_retries += 1
            self._link.write(report)
            ack = self._wait(lambda r: isinstance(r, Ack) and r.acked_report == rid, self.settings.ack_timeout_s)
            if isinstance(ack, Ack):
                if ack.error == 0:
                    return
                last = f"error code {ack.error:#04x}"
                self.log.warning("%s: the remote answered %s with %s", self.name, what, last)
            else:
                last = f"no acknowledgement within {self.settings.ack_timeout_s:.3f} s"
                self.log.debug("%s: %s: %s (try %d)", self.name, what, last, attempt + 1)
        raise WiimoteError(
            f"{self.name}: the remote did not accept {what} after {self.settings.write_retries} tries ({last}). "
            f"Is it still connected? Also, {KERNEL_DRIVER_HINT}"
        )

    def _setup(self) -> None:
        """LEDs, status, camera: everything after opening the transport."""
        self._streaming = False
        self.decoder.assembler.forget_half()
        self._link.write(encode_leds(self.settings.leds))
        self._link.write(encode_status_request())
        status = self._wait(lambda r: isinstance(r, StatusReport), self.settings.ack_timeout_s)
        if isinstance(status, StatusReport):
            self.stats.status_reports += 1
            self.decoder.battery = status.battery
        self._start_camera()

    def _start_camera(self) -> None:
        """Run the start sequence until IR reports arrive (`start_attempts` times at most)."""
        self._streaming = False
        self.decoder.assembler.end_segment()
        for attempt in range(self.settings.start_attempts):
            if attempt:
                self.stats.camera_restarts += 1
            self.stats.camera_starts += 1
            for step in self.start_steps:
                if step.expects_ack:
                    self._send_acked(step.report, step.what)
                else:
                    self._link.write(step.report)
            first = self._wait(lambda r: isinstance(r, IRReport), self.settings.stream_timeout_s)
            if first is not None:
                self._streaming = True
                self.decoder.last_ir_t = self.clock.now()
                self._set_state(
                    DriverState.STREAMING,
                    f"IR camera streaming ({self.settings.format.name.lower()}, {self.settings.sensitivity}, "
                    f"report {self.settings.report_mode:#04x}, player LED {self.settings.player_led})",
                )
                return
            self.log.warning(
                "%s: no IR reports within %.2f s after the start sequence (try %d of %d); restarting the camera",
                self.name,
                self.settings.stream_timeout_s,
                attempt + 1,
                self.settings.start_attempts,
            )
        raise WiimoteError(
            f"{self.name}: the IR camera did not start streaming after {self.settings.start_attempts} start sequences; "
            "power-cycle the remote (remove a battery) and reconnect it"
        )

    def read_registers(self, address: int, size: int, timeout_s: float | None = None) -> bytes:
        """Read `size` bytes of register space (0x17, collecting the 0x21 replies)."""
        with self._io_lock:
            self._link.write(encode_read(address, size))
            out = bytearray()
            deadline_s = self.settings.ack_timeout_s * (1 + size // 16) if timeout_s is None else timeout_s
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
        self.decoder.assembler.end_segment()
        self._link.close()
        self._backoff = self.settings.backoff_initial_s
        self._next_attempt = self.clock.now() + self._backoff
        self.log.warning("%s: lost the remote (%s); reconnecting with back-off", self.name, exc)
        self._set_state(DriverState.DISCONNECTED, f"lost the remote: {exc}")

    def _try_reconnect(self) -> bool:
        if self.clock.now() < self._next_attempt:
            return False
        try:
            self._link.open()
            self._setup()
        except (OSError, WiimoteError, DeviceAccessError) as exc:
            self.stats.reconnect_failures += 1
            self.last_error = str(exc)
            self._link.close()
            self._streaming = False
            self._backoff = min(self._backoff * 2.0, self.settings.backoff_max_s)
            self._next_attempt = self.clock.now() + self._backoff
            self.log.debug("%s: reconnect failed (%s); next try in %.2f s", self.name, exc, self._backoff)
            if self.state is not DriverState.DISCONNECTED:
                self._set_state(DriverState.DISCONNECTED, f"reconnect failed: {exc}")
            return False
        self.stats.reconnects += 1
        self._backoff = self.settings.backoff_initial_s
        self.log.info("%s: reconnected", self.name)
        return True
