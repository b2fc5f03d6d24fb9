"""Receiving what a rig publishes over Zenoh: `Subscription` queues the samples of a key
expression for the caller's thread (Zenoh calls back on its own threads), with the Unix time each
arrived; `decode` reads a payload (JSON when it is, text otherwise).
"""

from __future__ import annotations

import queue
import time
from dataclasses import dataclass
from typing import Any

from wiithrow.app.errors import AppError
from wiithrow.app.network.zenoh_session import one_line
from wiithrow.vision.errors import FileFormatError
from wiithrow.vision.files import loads_json


@dataclass(frozen=True)
class Received:
    """One sample: its key, its payload's bytes and when it arrived (Unix time, s)."""

    key: str
    payload: bytes
    received: float

    def decode(self) -> Any:
        return decode(self.payload)


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
    """The samples of `keyexpr` on an open `zenoh_session`, in arrival order (`get`)."""

    def __init__(self, zenoh_session: Any, keyexpr: str) -> None:
        self.keyexpr = key_expression(keyexpr)
        self._queue: queue.SimpleQueue[Received] = queue.SimpleQueue()
        self._subscriber = zenoh_session.declare_subscriber(self.keyexpr, self._on_sample)

    def _on_sample(self, sample: Any) -> None:
        received = time.time()  # first: what follows is this process's own work
        self._queue.put(Received(str(sample.key_expr), sample.payload.to_bytes(), received))

    def get(self, timeout_s: float | None = None) -> Received | None:
        """The next sample, waiting up to `timeout_s` (None: for ever); None when none came."""
        try:
            return self._queue.get(timeout=timeout_s)
        except queue.Empty:
            return None

    def close(self) -> None:
        try:
            self._subscriber.undeclare()
        except Exception:  # the Zenoh session closed first
            pass
