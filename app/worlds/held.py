"""IR sources a simulated person holds in front of the rig, after the world's own: a wand waved
for a wand calibration (`wave_wand`: `wiithrow.vision.wand.waver`'s path, starting now) or the
three LEDs of an L-frame (`hold`); `put_away()` (or `hold(None)`) takes them away.

Owns `HeldSources`, the `wiithrow.app.worlds.base.WandWaver` of both simulated worlds (the
kinematic `SimWorld` and the `MujocoWorld`): their simulated remotes look at the world's sources
and then at `held(t)` ((M, 3) in link1 at time t; none: (0, 3)).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence

import numpy as np
from numpy.typing import NDArray

from wiithrow.clock import Clock
from wiithrow.vision.camera import WiimoteCamera
from wiithrow.vision.wand.waver import WandPath, wand_path

#: IR sources (M, 3) in link1 at time t, held in front of the rig by a simulated person.
Held = Callable[[float], NDArray[np.float64]]

_NONE = np.zeros((0, 3))


class HeldSources:
    """What a simulated person holds in front of the rig of `cameras` (module docstring)."""

    def __init__(self, cameras: Sequence[WiimoteCamera], clock: Clock) -> None:
        self.cameras = list(cameras)
        self.clock = clock
        self._held: Held | None = None

    def __call__(self, t: float) -> NDArray[np.float64]:
        held = self._held
        return _NONE if held is None else np.asarray(held(t), dtype=float).reshape(-1, 3)

    @property
    def holding(self) -> bool:
        return self._held is not None

    def hold(self, sources: Held | NDArray[np.float64] | None) -> None:
        """Hold IR sources in front of the rig: a function of time giving (M, 3) in link1, or fixed
        positions (M, 3); None puts them away."""
        if sources is None or callable(sources):
            self._held = sources
        else:
            fixed = np.asarray(sources, dtype=float).reshape(-1, 3)
            self._held = lambda t: fixed

    def put_away(self) -> None:
        self._held = None

    def wave_wand(self, seconds: float, wand_length_m: float, rng: np.random.Generator) -> WandPath:
        """Wave a wand `wand_length_m` long in front of the rig for `seconds` from now
        (`wiithrow.vision.wand.waver.wand_path`; then it is put away). Returns its path (link1,
        times on the clock)."""
        t0 = self.clock.now()
        path = wand_path(self.cameras, seconds, rng, wand_length_m=wand_length_m)
        path = WandPath(path.times + t0, path.ends)
        end = t0 + seconds

        def ends(t: float) -> NDArray[np.float64]:
            return path.at(t) if t <= end else np.full((2, 3), np.nan)

        self.hold(ends)
        return path
