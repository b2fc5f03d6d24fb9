"""Many listeners of one stream of events: `Listeners`, and the `Unsubscribe` handle it returns.

Owns the one way a producer (a Wiimote's report decoder, a marker source) tells whoever listens:
`subscribe(listener)` adds a callable and returns the handle that removes it again; `emit(event)`
calls every listener in the order they subscribed. A listener that raises is counted
(`failures`) and logged, never raised into the producer: a broken view or a failed recording must
not stop the tracking. Subscribing and unsubscribing are safe from any thread; `emit` calls the
listeners present when it starts.
"""

from __future__ import annotations

import logging
import threading
from collections.abc import Callable
from typing import Generic, TypeVar

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
            except Exception:
                self.failures += 1
                if self.on_failure is not None:
                    self.on_failure()
                _log.exception("a listener of %s failed", self.name)
