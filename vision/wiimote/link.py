"""A remote's reports moved on the driver's clock: opening, writing, and reading with deadlines.

`RemoteLink` is the driver's side of a `Transport`: it opens it (or, given a factory, makes a new
one at every open, because a remote comes back under another device path after a reconnect),
writes reports exactly as long as they are and treats a short write as a lost link, and reads one
report by a deadline or drains a batch of them, every wait measured on the injected `Clock`. With
a `SimClock` a wait is a sleep on the clock in 1 ms steps, which is how simulations run faster than
real time. A vanished device shows as `OSError`, as from the transport itself.

Two things only a simulated remote can offer, used when the transport has them (`DueReports`):
it knows when its next report can be due (`nothing_due`: a poll before then need not read,
where a real device has to be asked), and it hands over every due report in one call
(`read_batch` then makes one call per batch instead of one per report and one more that finds
nothing). A real device is read report by report, as hidapi reads.
"""

from __future__ import annotations

import contextlib
import math
from collections.abc import Callable
from typing import Protocol, runtime_checkable

from wiithrow.clock import Clock
from wiithrow.vision.wiimote.protocol import MAX_REPORT_LENGTH
from wiithrow.vision.wiimote.transport import Transport

READ_SIZE = MAX_REPORT_LENGTH
IDLE_STEP_S = 0.001  # how long to sleep on the clock when a read returned nothing at once
MAX_BATCH = 4096  # reports drained per read_batch at most (a HID buffer holds far fewer)

#: A report due this close (s) after the clock's now counts as due: never skip a read for less.
DUE_SLACK_S = 1e-6

TransportOrFactory = Transport | Callable[[], Transport]


@runtime_checkable
class DueReports(Protocol):
    """A transport that knows when its reports are due (a simulated remote: see the module docstring)."""

    def next_report_due(self) -> float:
        """The earliest clock time a read can return something (-inf: now)."""

    def read_all(self, max_size: int) -> list[bytes]:
        """Every report due now, oldest first."""


class RemoteLink:
    """A `Transport`, or a factory of them, read and written on `clock` (see the module docstring)."""

    def __init__(self, transport: TransportOrFactory, clock: Clock) -> None:
        if isinstance(transport, Transport):
            self._transport: Transport | None = transport
            self._factory: Callable[[], Transport] | None = None
        elif callable(transport):
            self._transport = None
            self._factory = transport
        else:
            raise TypeError("transport must be a Transport or a callable returning one")
        self.clock = clock
        self._due: DueReports | None = None  # the transport, when it knows when reports are due

    @property
    def transport(self) -> Transport | None:
        """The transport in use (None while closed, when a factory makes them)."""
        return self._transport

    def open(self) -> None:
        """Open the transport (a new one from the factory, if given); `OSError` when it is not there."""
        if self._factory is not None:
            self._transport = self._factory()
        if self._transport is None:
            raise OSError("the transport factory gave no transport")
        self._due = self._transport if isinstance(self._transport, DueReports) else None
        self._transport.open()

    def nothing_due(self, now: float) -> bool:
        """True when the transport says no report can be read yet at clock time `now` (a read
        would return nothing and change nothing); False when it may have one or cannot tell (real
        devices)."""
        due = self._due
        return due is not None and now < due.next_report_due() - DUE_SLACK_S

    def quiet_until(self) -> float:
        """The clock time before which `nothing_due` holds (-inf when the transport cannot tell)."""
        due = self._due
        return -math.inf if due is None else due.next_report_due() - DUE_SLACK_S

    def close(self) -> None:
        """Release the transport; never raises (closing a vanished device must not fail)."""
        t = self._transport
        self._due = None
        if t is not None:
            with contextlib.suppress(Exception):
                t.close()
        if self._factory is not None:
            self._transport = None

    def write(self, report: bytes) -> None:
        """Send one report, exactly as long as it is; `OSError` when not open or written short."""
        n = self._open_transport().write(report)  # exactly the report's length, never padded
        if 0 <= n < len(report):
            raise OSError(f"short write of report {report[0]:#04x}: {n} of {len(report)} bytes")

    def read_until(self, deadline: float) -> tuple[float, bytes] | None:
        """One report and its arrival time, waiting on the clock until `deadline`; None on timeout."""
        t = self._open_transport()
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

    def read_batch(self, timeout_s: float) -> list[tuple[float, bytes]]:
        """The first report within `timeout_s`, then every report already waiting, with their
        arrival times; empty on timeout."""
        t = self._open_transport()
        due = self._due
        if due is not None and timeout_s <= 0:  # all at once (module docstring)
            reports = due.read_all(READ_SIZE)
            now = self.clock.now()  # arrived by now (as read_until stamps a report after reading it)
            return [(now, bytes(data)) for data in reports]
        first = self.read_until(self.clock.now() + max(0.0, timeout_s))
        if first is None:
            return []
        batch = [first]
        while len(batch) < MAX_BATCH:
            data = t.read(READ_SIZE, 0)
            if not data:
                break
            batch.append((self.clock.now(), bytes(data)))
        return batch

    def _open_transport(self) -> Transport:
        if self._transport is None:
            raise OSError("the remote is not open")
        return self._transport
