"""The hardware path's commands (`calibrate --robot`, `train`, `throw` with `--settings`) run in this
process over the MuJoCo drivers on a simulated clock, with a simulated operator at the terminal.

A lab runs these commands on the system clock; the drivers it names are the same code on either
clock (`HardwareWorld` takes its clock; the MuJoCo drivers' lab lives on the clock it is given).
Here `HardwareWorld`'s clock is a `SimClock` (the module's `SystemClock` replaced for the test), so
the run is as fast as the CPU allows and does not depend on the host's timing, and the operator
presses Enter at a prompt once the ball has come down and they have walked over (`WALK_S` on the
simulated clock), as the tests of the real-time path do after 2 s of real time. What a lab runs is
unchanged: nothing here is reachable from the command line.
"""

from __future__ import annotations

import contextlib
import io
import time
from dataclasses import dataclass, field

import pytest

from wiithrow.app.cli.main import main
from wiithrow.app.worlds import hardware
from wiithrow.app.worlds.mujoco.drivers import lab_of
from wiithrow.app.worlds.mujoco.lab import MujocoLab
from wiithrow.clock import SimClock

#: How long (s, simulated) the operator takes to walk over once the ball came down.
WALK_S = 1.0
#: How long (s, simulated) the operator looks for a ball that never came down before pressing Enter.
GIVE_UP_S = 10.0
#: How long (s, real) the operator waits for a simulated clock that does not move while they read
#: the prompt: a command that waits for the line without letting time pass (it let the ball come
#: down before it asked) is answered once the ball is down; a stuck one, without a touchdown, after
#: `STUCK_S` with the end of input.
STILL_S = 0.2
STUCK_S = 120.0


class Operator(io.TextIOBase):
    """stdin of the commands: each line is an Enter, pressed once the ball of the newest world has
    come down and `WALK_S` passed on its clock (or `GIVE_UP_S` passed without a touchdown), or once
    it is down while the command lets no time pass as it waits (`STILL_S`). No file descriptor: the
    commands read it with `readline`."""

    def __init__(self, run: SimulatedHardwarePath) -> None:
        self.run = run
        self.enters = 0

    def readable(self) -> bool:
        return True

    def fileno(self) -> int:
        raise io.UnsupportedOperation("the simulated operator has no file descriptor")

    def readline(self, size: int | None = -1) -> str:
        clock = self.run.clocks[-1]
        start, real = clock.now(), time.monotonic()
        last = start
        while True:
            lab = lab_of(clock)
            now = clock.now()
            touchdown = None if lab is None else lab.events.touchdown_at
            if (touchdown is not None and now >= touchdown + WALK_S) or now >= start + GIVE_UP_S:
                self.enters += 1
                return "\n"
            if now != last:
                last, real = now, time.monotonic()
            elif touchdown is not None and time.monotonic() - real > STILL_S:
                self.enters += 1
                return "\n"
            elif time.monotonic() - real > STUCK_S:
                return ""  # nobody moves the clock: the end of input, which the command says in one line
            time.sleep(0.001)


@dataclass
class SimulatedHardwarePath:
    """The commands' runs (`run`), the clocks their worlds were built on, and the operator."""

    clocks: list[SimClock] = field(default_factory=list)
    operator: Operator | None = None

    def clock(self) -> SimClock:
        self.clocks.append(SimClock())
        return self.clocks[-1]

    @property
    def lab(self) -> MujocoLab:
        """The MuJoCo lab of the newest world (its truth: where the ball came down)."""
        lab = lab_of(self.clocks[-1])
        assert lab is not None, "the newest world's drivers built no MuJoCo lab"
        return lab

    def run(self, *argv: str) -> tuple[int, str, str]:
        """`wiithrow argv` in this process: its exit status, stdout and stderr."""
        out, err = io.StringIO(), io.StringIO()
        with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
            code = main(list(argv))
        return code, out.getvalue(), err.getvalue()


@pytest.fixture
def simulated_hardware(monkeypatch: pytest.MonkeyPatch) -> SimulatedHardwarePath:
    """The hardware path on simulated clocks (module docstring)."""
    path = SimulatedHardwarePath()
    monkeypatch.setattr(hardware, "SystemClock", path.clock)
    path.operator = Operator(path)
    monkeypatch.setattr("sys.stdin", path.operator)
    return path
