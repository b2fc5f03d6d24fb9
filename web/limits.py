"""How much one dashboard connection may cost the server: the limits and the two small tools that
keep them.

Owns `Limits` (the numbers, with the reason for each), `TokenBucket` (a rate limit with a burst:
`delay()` says how long to wait before the next message may be read) and `Burst` (one event of a
burst, e.g. one Stop notification for 3 000 presses). `wiithrow.web.handshake` applies them to
every connection: a message over `max_message_bytes` closes the connection (websockets' own
`max_size`, checked frame by frame before the message is buffered whole); a connection that sends
faster than its rate is read more slowly (its messages wait in the kernel's socket buffer and
websockets' 16-frame queue, so it pushes back on the sender and costs the server no more than its
rate, and nothing it sent is lost: each Stop still stops; a sender whose backlog runs more than
20 s deep is closed by websockets' keepalive, whose pong waits behind it); past `max_guests`
guest connections, or more than `guest_connects_burst` new ones beyond `guest_connects_per_s`, a
new guest is refused with 503.

Why these numbers: viser 1.1's page sends its camera at most every 20 ms, a dragged gizmo every
50 ms and each GUI element's value every 50 ms (`useThrottledMessageSender` in
`viser/client/src`), so a person orbiting, dragging and clicking sends at most about 100
messages/s; its largest message is the camera's, 231 bytes (measured in Chromium, with a click
at 82). A page sends refused messages only when a guest moves a shared slider (at most 20/s).
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable
from dataclasses import dataclass


@dataclass(frozen=True)
class Limits:
    """Per-connection limits of the dashboard (see the module docstring)."""

    #: The largest message a client may send (bytes): 70 times the page's largest.
    max_message_bytes: int = 16 * 1024
    #: Messages a connection may have let through, per second, and in one burst (twice the page's most).
    admitted_per_s: float = 200.0
    admitted_burst: int = 200
    #: Messages refused on one connection, per second, and in one burst.
    refused_per_s: float = 20.0
    refused_burst: int = 40
    #: Guest connections at once (an operator's are not counted).
    max_guests: int = 16
    #: New guest connections per second, and in one burst: viser sends each new connection the
    #: whole scene (tens of ms of its event loop), so a guest connecting again and again would
    #: cost the operator what no flood of messages can.
    guest_connects_per_s: float = 0.5
    guest_connects_burst: int = 16
    #: Stops closer together than this (s) are one burst: one notification.
    stop_quiet_s: float = 2.0

    def __post_init__(self) -> None:
        if self.max_guests < 0:
            raise ValueError(f"max_guests must be >= 0, got {self.max_guests}")


class TokenBucket:
    """At most `rate` events per second on average, `burst` at once (a bucket of `burst` tokens,
    refilled at `rate` per second; each event takes one)."""

    def __init__(self, rate: float, burst: int, clock: Callable[[], float] = time.monotonic) -> None:
        if not rate > 0 or burst < 1:
            raise ValueError(f"a token bucket needs rate > 0 and burst >= 1, got {rate}, {burst}")
        self.rate, self.burst = float(rate), float(burst)
        self._clock = clock
        self._tokens = self.burst
        self._last = clock()

    def delay(self) -> float:
        """Take a token: 0 if one was there, else the seconds to wait for it (it is taken)."""
        now = self._clock()
        self._tokens = min(self.burst, self._tokens + (now - self._last) * self.rate)
        self._last = now
        self._tokens -= 1.0
        return 0.0 if self._tokens >= 0 else -self._tokens / self.rate

    def take(self) -> bool:
        """Take a token if there is one (True), else take nothing (False)."""
        if self.delay() == 0.0:
            return True
        self._tokens += 1.0
        return False


class Burst:
    """`first()` is True for the first event of a burst: events less than `quiet_s` apart are one
    burst (each event extends it); `count` is the events of the current burst."""

    def __init__(self, quiet_s: float, clock: Callable[[], float] = time.monotonic) -> None:
        self.quiet_s = float(quiet_s)
        self._clock = clock
        self._last = -float("inf")
        self._lock = threading.Lock()  # Stop's callbacks run in viser's thread pool
        self.count = 0

    def first(self) -> bool:
        with self._lock:
            now = self._clock()
            new = now - self._last >= self.quiet_s
            self._last = now
            self.count = 1 if new else self.count + 1
            return new
