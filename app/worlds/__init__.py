"""The worlds the running system acts in: `RigWorld` (what every world shares), `SimWorld` (the
simulated arm, remotes and IR sources) and, in `wiithrow.app.worlds.hardware`, `HardwareWorld`
(the real remotes through hidapi and the real arm through its driver)."""

from wiithrow.app.worlds.base import BEACON_DISTANCE_M, SOURCES, RigWorld, nominal_cameras, source_index
from wiithrow.app.worlds.simulated import SimWorld

__all__ = ["BEACON_DISTANCE_M", "SOURCES", "RigWorld", "SimWorld", "nominal_cameras", "source_index"]
