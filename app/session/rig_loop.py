"""The session's real-time loop: `RigLoop` keeps reading the rig while no operation runs (an
operation reads it itself), in a thread of its own.

A read that fails does not end the loop: its one line is the session's status message
(`READ_FAILED` + the error), once per distinct error, and the first read that succeeds afterwards
clears it, unless something newer replaced it meanwhile (`clear_message(text)` clears only
`text`). So a status line never shows a failure that is over.

On a simulated clock (`SimClock`: the hardware path's tests run the MuJoCo drivers on one) the loop
lets simulated time pass only while no operation runs: an operation lets time pass itself, and a
second thread moving the clock meanwhile would make its waits jump ahead (a host late at random);
while one runs the loop waits `BUSY_WAIT_S` of real time before it looks again.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable

from wiithrow.app.worlds import RigWorld
from wiithrow.clock import SimClock

#: The head of the status message of a failed read of the rig.
READ_FAILED = "rig read failed: "
#: How long (s, real time) the loop of a simulated clock waits while an operation runs.
BUSY_WAIT_S = 0.001


class RigLoop:
    """Polls `world.rig` every `period_s` (world clock) while `busy()` is false; `tell(text)` shows
    a failed read, `clear_message(text)` takes it back once reads succeed again."""

    def __init__(
        self,
        world: RigWorld,
        *,
        busy: Callable[[], bool],
        tell: Callable[[str], None],
        clear_message: Callable[[str], None],
        period_s: float = 0.01,
    ) -> None:
        self.world = world
        self._busy, self._tell, self._clear = busy, tell, clear_message
        self.period_s = float(period_s)
        self._running = threading.Event()
        self._thread: threading.Thread | None = None

    def start(self) -> None:
        if self._thread is not None:
            return
        self._running.set()
        self._thread = threading.Thread(target=self._run, name="wiithrow-rig", daemon=True)
        self._thread.start()

    def stop(self, timeout_s: float = 2.0) -> None:
        self._running.clear()
        if self._thread is not None:
            self._thread.join(timeout=timeout_s)
            self._thread = None

    def _run(self) -> None:
        failed = ""  # the message of the last failed read, until a read succeeds
        simulated = isinstance(self.world.clock, SimClock)
        while self._running.is_set():
            if simulated and self._busy():  # the operation lets time pass (module docstring)
                time.sleep(BUSY_WAIT_S)
                continue
            try:
                idle = not self._busy()
                if idle:
                    self.world.rig.poll()
            except Exception as exc:  # keep the loop alive; say what happened
                message = f"{READ_FAILED}{exc}"
                if message != failed:
                    failed = message
                    self._tell(message)
            else:
                if idle and failed:
                    self._clear(failed)
                    failed = ""
            self.world.clock.sleep(self.period_s)
