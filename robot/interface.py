"""The arm interface: what the rest of the system may ask of an arm, real or simulated.

`Arm` is a `typing.Protocol`; `SimulatedArm` and `ParkedArm` (no driver: it refuses to move)
implement it, and a driver for a real PA-10 would too. `JointState` is one timestamped reading. The time source an arm needs is the project's one
`wiithrow.clock.Clock` (re-exported here as `robot.Clock`).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Protocol, runtime_checkable

import numpy as np
from numpy.typing import NDArray

from wiithrow.clock import Clock
from wiithrow.robot.trajectory import JointTrajectory

__all__ = ["Arm", "Clock", "JointState"]


@dataclass(frozen=True)
class JointState:
    """The arm's joint state at time `t` (s, on the arm's clock): `q` (rad), `dq` (rad/s), (nq,) each."""

    t: float
    q: NDArray[np.float64]
    dq: NDArray[np.float64]


@runtime_checkable
class Arm(Protocol):
    """A position-controlled arm. All positions are joint angles (rad), in the arm's joint order."""

    def state(self) -> JointState:
        """The current joint state."""
        ...

    def command_position(self, q: NDArray[np.float64]) -> None:
        """Move to `q` (and stop there) along a jerk-limited Ruckig trajectory from the current state.

        Replaces any running command. Raises LimitError (naming the joint) if `q` is outside the
        position limits.
        """
        ...

    def command_trajectory(self, traj: JointTrajectory) -> None:
        """Follow a pre-computed, already validated, sampled trajectory, starting now.

        Its first sample must match the current state (else `StartMismatchError`, and nothing moves).
        Replaces any running command.
        """
        ...

    def stop(self) -> None:
        """Brake to rest at once, within the velocity, acceleration and jerk limits."""
        ...

    def is_moving(self) -> bool:
        """True while a command runs or the joints still move."""
        ...

    def wait_until_idle(self, timeout: float) -> bool:
        """Wait (on the arm's clock) until the arm is idle; False if `timeout` (s) passed first."""
        ...
