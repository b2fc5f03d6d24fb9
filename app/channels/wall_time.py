"""Wall time: a run's clock mapped to Unix time, once, so that every sink stamps alike.

The rig runs on a `Clock`: the system's monotonic clock (seconds since the machine started) on
hardware, a `SimClock` (seconds since the simulation started) in a simulated world. A user's tools
expect Unix time: Foxglove's timeline, ROS 2's header stamps, a recording's log times. So each
clock is mapped to Unix time once, the first time a sink asks (`wall_time(clock)`, at the start
of a run): `unix = t + offset`, `offset = time.time() - clock.now()` then. Every sink of the run
asks for the same clock and gets the same offset, so Foxglove's timeline and the ROS 2 stamps of
one frame agree to the nanosecond; the messages' own `t` fields stay on the rig's clock (what a
replay feeds the pipeline again), and a recording states the offset in its metadata
(`unix_offset_ns`), so either is had from the other.

On the system clock the mapping is the machine's: monotonic to Unix time, as NTP had it at the
start (a later step of the machine's clock is not followed: the stamps stay monotonic). A
simulated run is stamped the same way: its clock's start is the Unix time at which it started,
and its stamps then advance with the simulation (ahead of the machine's clock when the simulation
runs faster than real time, behind it when slower).
"""

from __future__ import annotations

import threading
import time
import weakref
from dataclasses import dataclass

from wiithrow.clock import Clock

NS_PER_S = 1_000_000_000


@dataclass(frozen=True)
class WallTime:
    """`unix_ns = round(t * 1e9) + offset_ns` for a time `t` (s) on the run's clock."""

    offset_ns: int

    def stamp_ns(self, t: float) -> int:
        """The Unix time (ns) of `t` (s, the run's clock)."""
        return round(t * NS_PER_S) + self.offset_ns

    def t_of(self, stamp_ns: int) -> float:
        """The run's clock (s) at Unix time `stamp_ns`."""
        return (stamp_ns - self.offset_ns) / NS_PER_S


#: For messages already stamped in Unix time, or recordings made before the mapping (offset 0).
UNMAPPED = WallTime(0)

_mappings: weakref.WeakKeyDictionary[Clock, WallTime] = weakref.WeakKeyDictionary()
_lock = threading.Lock()


def wall_time(clock: Clock) -> WallTime:
    """The mapping of `clock` to Unix time, fixed the first time it is asked for (module docstring)."""
    with _lock:
        mapping = _mappings.get(clock)
        if mapping is None:
            mapping = _mappings[clock] = WallTime(time.time_ns() - round(clock.now() * NS_PER_S))
        return mapping


def stamp(stamp_ns: int) -> dict[str, int]:
    """A Unix time (ns) as the `{sec, nsec}` of Foxglove's `Time`."""
    sec, nsec = divmod(stamp_ns, NS_PER_S)
    return {"sec": sec, "nsec": nsec}
