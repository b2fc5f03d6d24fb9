"""The simulated worlds by name, for the command line and the studies.

Owns `WORLDS` and `make_world(name, ...)`: `"kinematic"` is the `SimWorld`, whose arm and ball are
the planner's own models (fast; what most tests want); `"mujoco"` is the `MujocoWorld`, physics the
planner does not know, reached through the hardware interfaces (`wiithrow.app.worlds.mujoco`).
"""

from __future__ import annotations

from wiithrow.app.errors import AppError
from wiithrow.app.settings import Settings
from wiithrow.app.worlds.base import RigWorld
from wiithrow.app.worlds.simulated import SimWorld

#: The simulated worlds' names.
WORLDS = ("mujoco", "kinematic")


def make_world(name: str, settings: Settings | None = None, *, seed: int = 0, realtime: bool = False) -> RigWorld:
    """The simulated world called `name` (one of `WORLDS`); AppError naming them otherwise."""
    if name == "kinematic":
        return SimWorld(settings, seed=seed, realtime=realtime)
    if name == "mujoco":
        from wiithrow.app.worlds.mujoco.world import MujocoWorld

        return MujocoWorld(settings, seed=seed, realtime=realtime)
    raise AppError(f"unknown world {name!r}: one of {', '.join(WORLDS)}")
