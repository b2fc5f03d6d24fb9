"""What a `WiimoteDriver` is configured with, and what it reports about itself.

`DriverSettings` holds every option of a driver (the IR camera's setup, the timeouts and retries
of its start sequence, the reconnect back-off, the frame queue), validated when it is made, with
the reporting mode and start sequence they imply. `DriverState` is the driver's connection state,
`DriverStats` the counters of its life, `WiimoteError` what it raises when the remote does not
follow the protocol. Plain data: the behaviour is `device`'s.
"""

from __future__ import annotations

import enum
from dataclasses import dataclass

from wiithrow.vision.errors import VisionError
from wiithrow.vision.wiimote.output_reports import StartStep, ir_start_sequence
from wiithrow.vision.wiimote.protocol import (
    DEFAULT_SENSITIVITY,
    IN_BUTTONS_ACCEL_IR10_EXT6,
    REPORT_MODES,
    IRFormat,
    ProtocolError,
    player_leds,
    sensitivity_blocks,
)


class WiimoteError(VisionError):
    """The remote does not do what the protocol says (no acknowledgement, no IR stream)."""


class DriverState(str, enum.Enum):
    CLOSED = "closed"
    CONNECTING = "connecting"
    STREAMING = "streaming"
    DISCONNECTED = "disconnected"


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


@dataclass(frozen=True)
class DriverSettings:
    """A driver's options. Making one checks them: an unknown sensitivity or IR format, a player
    outside 1-4 or a basic report mode other than 0x36/0x37 raise `ProtocolError`.

    The IR camera:
    - `sensitivity`: a named sensitivity setting (`protocol.SENSITIVITY_BLOCKS`), case-insensitive;
    - `ir_format`: "basic", "extended" or "full" (or an `IRFormat`);
    - `player_led`: the player LED (1-4) the remote shows;
    - `basic_report_mode`: 0x36 or 0x37, the report that carries the basic format (ignored for
      the others: extended comes in 0x33, full in 0x3E/0x3F).

    The start sequence and the stream (seconds on the driver's clock):
    - `ack_timeout_s`: how long to wait for each acknowledgement (and for the status report);
    - `write_retries`: tries per acknowledged write (at least 1: a smaller number counts as 1);
    - `stream_timeout_s`: how long after the start sequence the first IR report may take before
      the sequence is run again;
    - `start_attempts`: start sequences before giving up (at least 1);
    - `stall_timeout_s`: a gap without IR reports while streaming after which the camera is
      restarted.

    Reconnecting after a lost link (seconds): the first attempt `backoff_initial_s` after the loss,
    then the wait doubles after every failed attempt, up to `backoff_max_s`.

    `queue_size`: frames the background reader's queue holds (at least 1) before it drops the
    oldest.
    """

    sensitivity: str = DEFAULT_SENSITIVITY
    ir_format: IRFormat | str = IRFormat.EXTENDED
    player_led: int = 1
    basic_report_mode: int = IN_BUTTONS_ACCEL_IR10_EXT6
    ack_timeout_s: float = 0.1
    write_retries: int = 3
    stream_timeout_s: float = 0.5
    start_attempts: int = 4
    stall_timeout_s: float = 0.5
    backoff_initial_s: float = 0.1
    backoff_max_s: float = 5.0
    queue_size: int = 4096

    def __post_init__(self) -> None:
        fmt = IRFormat.from_name(self.ir_format)
        sensitivity_blocks(self.sensitivity)  # validates the name
        player_leds(self.player_led)  # validates the player
        if fmt is IRFormat.BASIC and self.basic_report_mode not in REPORT_MODES[IRFormat.BASIC]:
            raise ProtocolError(f"basic IR comes in report 0x36 or 0x37, not {self.basic_report_mode:#04x}")
        normalized = {
            "ir_format": fmt,
            "sensitivity": str(self.sensitivity).lower(),
            "player_led": int(self.player_led),
            "basic_report_mode": int(self.basic_report_mode),
            "ack_timeout_s": float(self.ack_timeout_s),
            "write_retries": max(1, int(self.write_retries)),
            "stream_timeout_s": float(self.stream_timeout_s),
            "start_attempts": max(1, int(self.start_attempts)),
            "stall_timeout_s": float(self.stall_timeout_s),
            "backoff_initial_s": float(self.backoff_initial_s),
            "backoff_max_s": float(self.backoff_max_s),
            "queue_size": max(1, int(self.queue_size)),
        }
        for name, value in normalized.items():
            object.__setattr__(self, name, value)

    @property
    def format(self) -> IRFormat:
        """`ir_format` as an `IRFormat`."""
        return IRFormat.from_name(self.ir_format)

    @property
    def report_mode(self) -> int:
        """The input report that carries the IR format (0x33, 0x36/0x37 or 0x3E)."""
        fmt = self.format
        return self.basic_report_mode if fmt is IRFormat.BASIC else REPORT_MODES[fmt][0]

    @property
    def leds(self) -> int:
        """The LED bits of `player_led`."""
        return player_leds(self.player_led)

    def start_steps(self) -> list[StartStep]:
        """The IR camera's start sequence for these settings (`output_reports.ir_start_sequence`)."""
        return ir_start_sequence(self.sensitivity, self.format, self.report_mode)
