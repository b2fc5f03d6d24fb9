"""An arm without a driver: it reports where it was parked and refuses to move.

`ParkedArm` implements `wiithrow.robot.interface.Arm` for a running system whose real arm has no driver
(`wiithrow serve` with the remotes alone): the rig on link1 still tracks markers, and link1 is
placed by the parked pose (the operator parks the real arm there, by default at its home pose).
Every motion command raises `RobotError` saying that no arm driver is connected; `stop` and the
idle queries succeed (there is nothing to stop), so Stop always works.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike

from wiithrow.robot.errors import RobotError
from wiithrow.robot.interface import Clock, JointState
from wiithrow.robot.trajectory import JointTrajectory

NO_DRIVER = (
    "no arm driver is connected: the arm is shown where it was parked and cannot move "
    "(name a driver in the settings' `arm_driver`, 'module:factory')"
)


class ParkedArm:
    """An `Arm` that stays at `q` (rad) and refuses every motion (see the module docstring)."""

    connected = False

    def __init__(self, q: ArrayLike, clock: Clock) -> None:
        self._q = np.array(q, dtype=float).reshape(-1)
        if not np.isfinite(self._q).all():
            raise RobotError(f"the parked pose must be finite, got {self._q}")
        self.clock = clock

    def state(self) -> JointState:
        return JointState(self.clock.now(), self._q.copy(), np.zeros_like(self._q))

    def command_position(self, q: ArrayLike) -> None:
        raise RobotError(NO_DRIVER)

    def command_trajectory(self, traj: JointTrajectory) -> None:
        raise RobotError(NO_DRIVER)

    def stop(self) -> None:
        """Nothing moves: nothing to do."""

    def is_moving(self) -> bool:
        return False

    def wait_until_idle(self, timeout: float) -> bool:
        return True
