"""Receiving what a rig publishes over Zenoh: `Subscription` queues the samples of a key
expression for the caller's thread (Zenoh calls back on its own threads), with the Unix time each
arrived; `decode` reads a payload (JSON when it is, text otherwise).

The queue is bounded (`max_queued`, default `MAX_QUEUED`): a sample that comes when it is full
pushes out the oldest, and `dropped` counts them, so a flood costs at most the bound in memory and
a slow reader finds the newest samples. With a `verifier` (`wiithrow.app.network.frame_auth`) each
sample's signature is checked in the callback, before it is queued: an unsigned, forged or
replayed sample is counted in `refused` by reason and never queued nor decoded, so that a flood of
forged frames costs this process a hash each and never a place in the queue. A payload longer than
`max_payload_bytes` is refused there too (`malformed`), unread.
"""

from __future__ import annotations

import threading
import time
from collections import Counter, deque
from dataclasses import dataclass
from typing import Any

from wiithrow.app.errors import AppError
from wiithrow.app.network.frame_auth import FrameVerifier
from wiithrow.app.network.zenoh_session import one_line
from wiithrow.vision.errors import FileFormatError
from wiithrow.vision.files import loads_json

#: The samples a subscription keeps for its reader by default: 100 s of markers at 100 Hz, about
#: 15 MB of the largest frames; a reader with a tighter bound says so (`RemoteRig`).
MAX_QUEUED = 10_000
#: Why `refused` counts a payload over `max_payload_bytes`.
TOO_LARGE = "malformed"


@dataclass(frozen=True)
class Received:
    """One sample: its key, its payload's bytes and when it arrived (Unix time, s)."""

    key: str
    payload: bytes
    received: float

    def decode(self) -> Any:
        return decode(self.payload)


@dataclass(frozen=True)
class Counts:
    """What a subscription counted before its queue, since the last `Subscription.take_counts`."""

    arrived: int
    dropped: int
    refused: Counter[str]


def decode(payload: bytes) -> Any:
    """A payload as JSON when it parses and nests no deeper than `MAX_JSON_DEPTH`
    (`wiithrow.vision.files.loads_json`), else as text (invalid UTF-8 replaced): a payload is
    never a `RecursionError`."""
    text = payload.decode("utf-8", errors="replace")
    try:
        return loads_json(text, "payload")
    except FileFormatError:
        return text


def key_expression(text: str) -> str:
    """`text` if it is a valid Zenoh key expression, else AppError."""
    import zenoh

    try:
        return str(zenoh.KeyExpr(text))
    except Exception as exc:
        raise AppError(f"not a Zenoh key expression: {text!r} ({one_line(exc)})") from None


class Subscription:
    """The samples of `keyexpr` on an open `zenoh_session`, in arrival order (`get`); see the
    module docstring for `max_queued`, `verifier` and `max_payload_bytes`."""

    def __init__(
        self,
        zenoh_session: Any,
        keyexpr: str,
        *,
        max_queued: int = MAX_QUEUED,
        verifier: FrameVerifier | None = None,
        max_payload_bytes: int | None = None,
    ) -> None:
        self.keyexpr = key_expression(keyexpr)
        self.max_queued = max(1, int(max_queued))
        self._queue: deque[Received] = deque()
        self._ready = threading.Condition(threading.Lock())
        self._verifier = verifier
        self._max_payload = max_payload_bytes
        self.arrived = 0  # every sample, queued or not
        self.dropped = 0  # pushed out of a full queue
        self.refused: Counter[str] = Counter()  # refused before the queue, by reason
        self._taken = Counts(0, 0, Counter())
        self._subscriber = zenoh_session.declare_subscriber(self.keyexpr, self._on_sample)

    def _on_sample(self, sample: Any) -> None:
        received = time.time()  # first: what follows is this process's own work
        payload = sample.payload
        if self._max_payload is not None and len(payload) > self._max_payload:
            with self._ready:
                self.arrived += 1
                self.refused[TOO_LARGE] += 1
            return
        key, data = str(sample.key_expr), payload.to_bytes()
        attachment = sample.attachment
        signature = attachment.to_bytes() if attachment is not None else None
        with self._ready:
            self.arrived += 1
            if self._verifier is not None:
                why = self._verifier.check(key, data, signature)
                if why is not None:
                    self.refused[why] += 1
                    return
            if len(self._queue) >= self.max_queued:
                self._queue.popleft()
                self.dropped += 1
            self._queue.append(Received(key, data, received))
            self._ready.notify()

    @property
    def queued(self) -> int:
        """Samples waiting for `get`."""
        return len(self._queue)

    def get(self, timeout_s: float | None = None) -> Received | None:
        """The next sample, waiting up to `timeout_s` (None: for ever); None when none came."""
        with self._ready:
            if not self._queue and timeout_s != 0.0:
                self._ready.wait_for(lambda: bool(self._queue), timeout_s)
            return self._queue.popleft() if self._queue else None

    def take_counts(self) -> Counts:
        """What was counted before the queue since the last call (samples arrived, dropped, refused)."""
        with self._ready:
            now = Counts(self.arrived, self.dropped, Counter(self.refused))
        before, self._taken = self._taken, now
        refused = now.refused.copy()
        refused.subtract(before.refused)
        return Counts(now.arrived - before.arrived, now.dropped - before.dropped, +refused)

    def close(self) -> None:
        try:
            self._subscriber.undeclare()
        except Exception:  # the Zenoh session closed first
            pass
