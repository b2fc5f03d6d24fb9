"""Many listeners of one stream of events: `Listeners`, and the `Unsubscribe` handle it returns.

Owns the one way a producer (a Wiimote's report decoder, a marker source) tells whoever listens:
`subscribe(listener)` adds a callable and returns the handle that removes it again; `emit(event)`
calls every listener in the order they subscribed. A listener that raises is counted
(`failures`) and logged in one line (once per distinct fault), never raised into the producer: a broken view or a failed recording must
not stop the tracking. Subscribing and unsubscribing are safe from any thread; `emit` calls the
listeners present when it starts.

Also the end of a batch of events: a producer that emits several events in one go (a marker
source's poll: each camera's frames, then the flush) wraps them in `batch()`, outside its lock;
a listener that has something to do once per batch, after the producer let go of its lock, asks
for it with `after_batch(key, action)` (one action per key, run when the outermost batch of this
thread ends; at once outside a batch). What it is for: waking a writer process once per poll,
when the poll is over (`wiithrow.app.channels.frame_ring.FrameRing.wake`). A writer woken at each
event of a poll ran on the tracking thread's core in the middle of the poll: the tracking thread
was preempted (counted as involuntary context switches) and the frame's other consumers waited
(`wiithrow bench latency`).
"""

from __future__ import annotations

import logging
import threading
from collections.abc import Callable, Hashable, Iterator
from contextlib import contextmanager
from typing import Generic, TypeVar

from wiithrow.fault_lines import MAX_DISTINCT_FAULTS, describe

Event = TypeVar("Event")

_log = logging.getLogger("wiithrow.listeners")


class Unsubscribe:
    """Removes one listener when called (again: nothing happens)."""

    def __init__(self, remove: Callable[[], None]) -> None:
        self._remove: Callable[[], None] | None = remove

    def __call__(self) -> None:
        remove, self._remove = self._remove, None
        if remove is not None:
            remove()


class Listeners(Generic[Event]):
    """The listeners of one stream of events (see the module docstring)."""

    def __init__(self, name: str, *, on_failure: Callable[[], object] | None = None) -> None:
        self.name = name
        self.failures = 0
        self.on_failure = on_failure  # told of each failure too (a driver counts them in its stats)
        self._listeners: tuple[Callable[[Event], object], ...] = ()
        self._lock = threading.Lock()
        self._told: set[str] = set()  # the faults of listeners already logged

    def subscribe(self, listener: Callable[[Event], object]) -> Unsubscribe:
        """Call `listener(event)` for every event from now on; the handle removes it."""
        with self._lock:
            self._listeners = (*self._listeners, listener)

        def remove() -> None:
            with self._lock:
                kept = list(self._listeners)
                if listener in kept:
                    kept.remove(listener)
                self._listeners = tuple(kept)

        return Unsubscribe(remove)

    def __bool__(self) -> bool:
        """Whether anybody listens (a producer may skip building an event nobody reads)."""
        return bool(self._listeners)

    def __len__(self) -> int:
        return len(self._listeners)

    def emit(self, event: Event) -> None:
        for listener in self._listeners:
            try:
                listener(event)
            except Exception as exc:
                self.failures += 1
                if self.on_failure is not None:
                    self.on_failure()
                fault = describe(exc)
                if fault not in self._told and len(self._told) < MAX_DISTINCT_FAULTS:  # one line per kind
                    self._told.add(fault)
                    _log.error("a listener of %s failed: %s (told once; the events go on)", self.name, fault)


_batches = threading.local()  # .pending: this thread's open batch, key -> action (None: no batch)


@contextmanager
def batch() -> Iterator[None]:
    """The events emitted on this thread inside are one batch: the actions asked for with
    `after_batch` meanwhile run once each when the outermost batch ends (module docstring). An
    action that raises is logged; the others still run."""
    if getattr(_batches, "pending", None) is not None:  # nested: the outermost batch runs them
        yield
        return
    _batches.pending = {}
    try:
        yield
    finally:
        pending: dict[Hashable, Callable[[], object]] = _batches.pending
        _batches.pending = None
        for action in pending.values():
            try:
                action()
            except Exception as exc:
                _log.error("an action at the end of a batch of events failed: %s", describe(exc))


def after_batch(key: Hashable, action: Callable[[], object]) -> bool:
    """Run `action` when this thread's batch ends, once per `key` (a later action for the same key
    replaces the earlier); True if so, False (nothing done) when no batch is open: the caller acts now."""
    pending: dict[Hashable, Callable[[], object]] | None = getattr(_batches, "pending", None)
    if pending is None:
        return False
    pending[key] = action
    return True
