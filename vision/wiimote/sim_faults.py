"""The simulated remote's test interface: the faults it is told to show and what it reports doing.

`SimFaults` lists the faults a `SimulatedWiimote` injects (all off by default; the remote works on
a copy, since faults get used up), `SimStats` counts what it did, and `SentReport` is the truth
behind each data report it produced (what the tests compare decoded dots with).
"""

from __future__ import annotations

from dataclasses import dataclass


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
