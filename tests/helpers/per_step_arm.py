"""`PerStepArm`: the simulated servo one step at a time, the reference its fast paths must equal."""

from __future__ import annotations

from wiithrow.robot import SimulatedArm


class PerStepArm(SimulatedArm):
    """`SimulatedArm` without the vectorised stretches of exact following (`_follow`): every step
    is `_step`'s, the servo law as the module docstring writes it."""

    def _follow(self, Q, V, row, m):
        return 0
