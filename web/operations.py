"""Running the session's operations for the dashboard: worker threads and what the clients are told.

Owns `OperationRunner`. A button click arrives on viser's callback thread pool; the operation it
starts (calibrate, track, preview, throw: seconds to a minute) runs in a worker thread of its own,
never on the callback thread. One at a time: a click while a worker runs, or one that loses the
race for the session's lock (`wiithrow.app.session.session.Busy`, which is the real guarantee, whoever calls), gets
a notification saying what runs, never a second motion. Workers belong to the dashboard, not to a
browser, so a browser that disconnects mid-throw does not stop the throw from finishing safely;
Stop from any client cancels it (`Session.stop`, called directly: it never waits).

Notifications go to the client that asked (refusals, failures of its request) or to everyone
(results and failures everyone should see); a client that went away is skipped.
"""

from __future__ import annotations

import threading
import traceback
from collections.abc import Callable
from typing import Any

from wiithrow.app.errors import expected_errors
from wiithrow.app.session import Busy, Operation, Session, busy_reason

Notify = Callable[[Any, str, str, Any], None]  # (client or None for all, title, body, colour name)


class OperationRunner:
    """Starts session operations in worker threads (see the module docstring)."""

    def __init__(self, session: Session, notify: Notify) -> None:
        self.session = session
        self.notify = notify
        self._lock = threading.Lock()
        self._worker: threading.Thread | None = None
        self._operating = False  # from a start until its operation returned (not its notifications)
        self.started = 0  # operations handed to a worker
        self.refused = 0  # clicks refused because one was running

    @property
    def running(self) -> bool:
        """An operation was started and has not returned yet. Its worker may live on a moment
        longer, telling the clients how it went: that tail never refuses the next click (under a
        load of 4 a click on a button the page showed enabled, the session idle, was refused as
        Busy because the last worker had not yet ended)."""
        return self._operating

    def start(
        self,
        op: Operation,
        operation: Callable[[], Any],
        *,
        client: Any = None,
        done: Callable[[Any], tuple[str, str] | None] | None = None,
    ) -> bool:
        """Run `operation()` (the session's `op`) in a worker thread unless one runs; `done(result)` may return a
        (title, body) notification for everyone. Returns False (and tells `client`) if refused."""
        with self._lock:
            if self.running or self.session.busy:
                self.refused += 1
                self.notify(client, "Busy", busy_reason(self.session.operation), "yellow")
                return False
            worker = threading.Thread(
                target=self._run,
                args=(op, operation, client, done),
                name=f"wiithrow-web-{op.name.lower()}",
                daemon=True,
            )
            self._worker = worker
            self._operating = True
            self.started += 1
            worker.start()
            return True

    def _run(
        self,
        op: Operation,
        operation: Callable[[], Any],
        client: Any,
        done: Callable[[Any], tuple[str, str] | None] | None,
    ) -> None:
        try:
            try:
                result = operation()
            finally:
                self._operating = False
        except Busy as exc:
            self.notify(client, "Busy", str(exc), "yellow")
            return
        except expected_errors() as exc:
            self.notify(None, f"{op.title} did not complete", str(exc), "red")
            return
        except Exception as exc:  # a bug: keep the dashboard alive, say so, keep the traceback
            traceback.print_exc()
            self.notify(None, f"{op.title} failed", f"internal error: {exc!r}", "red")
            return
        if done is not None:
            message = done(result)
            if message is not None:
                self.notify(None, message[0], message[1], "green")

    def join(self, timeout: float | None = None) -> None:
        """Wait for the running worker (tests, shutdown)."""
        worker = self._worker
        if worker is not None:
            worker.join(timeout)
