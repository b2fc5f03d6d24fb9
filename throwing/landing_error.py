"""A throw's error: where the ball came down against the target, in 3D, split the way an operator
reads it. The one definition every view uses (the session's records, the dashboard, the command
line, the JSON, the recording), for the rig's measurement and for a simulation's truth alike.

Both points are in `base` (m): the target T as the rig measured it when joint 1 was aligned to
it, the landing L as the rig measured the marker put where the ball first touched down, each taken
to `base` by the joint-1 angle the arm read while it was measured (`throw_plane.turned`: the rig
is on link1). Joint 1's axis is base's z axis, so the target's *throw plane* is the vertical plane
through that axis and the target, at azimuth psi = atan2(T_y, T_x): link1 turned onto the target.
With u = (cos psi, sin psi, 0) along the throw, n = (-sin psi, cos psi, 0) across it and
d = L - T:

    along  = d . u      x of link1 turned onto the target: + beyond the target, - short of it
    across = d . n      y of link1 turned onto the target: + toward link1's +y (counter-clockwise
                        seen from above), - toward its -y
    height = d_z        the landing's height over the target's (~0 when both are on one surface)
    total  = sqrt(along^2 + across^2)   the distance on the landing surface

The total is the horizontal distance |L_xy - T_xy|: it does not depend on the split, nor on the
joint-1 angle of the throw, which the learned sideways correction turns away from the target's
azimuth (`wiithrow.throwing.lateral`). A measurement of the throw plane's (x, z) alone
misses the across part entirely: a ball that lands 15 mm beside the plane at the
right distance reads as a hit.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike


@dataclass(frozen=True)
class LandingError:
    """A landing against its target (module docstring), m; NaN where a point is unknown."""

    along_m: float
    across_m: float
    height_m: float

    @property
    def total_m(self) -> float:
        """The distance on the landing surface: sqrt(along^2 + across^2) (m)."""
        return math.hypot(self.along_m, self.across_m)

    @property
    def known(self) -> bool:
        """True when both points were known (the figures are finite)."""
        return math.isfinite(self.total_m)

    def to_dict(self) -> dict[str, float]:
        """As JSON: `along_m`, `across_m`, `height_m`, `total_m` (NaN where unknown; null once written)."""
        return {"along_m": self.along_m, "across_m": self.across_m, "height_m": self.height_m, "total_m": self.total_m}

    def words(self, unit: str = "mm") -> str:
        """ "15.3 mm (along +3.0, across -15.0)": the total, then the parts, signed, in `unit` ("mm"
        or "cm", `PER_METRE`), one decimal."""
        scale = PER_METRE[unit]
        return f"{scale * self.total_m:.1f} {unit} (along {scale * self.along_m:+.1f}, across {scale * self.across_m:+.1f})"


#: How many of each unit an error may be shown in make a metre.
PER_METRE = {"mm": 1000.0, "cm": 100.0}

UNKNOWN = LandingError(math.nan, math.nan, math.nan)


def landing_error(landing_base: ArrayLike | None, target_base: ArrayLike | None) -> LandingError:
    """The landing `landing_base` against the target `target_base` (both (3,) in `base`, m; module
    docstring). `UNKNOWN` (NaN) when either is None or not finite, or the target is on joint 1's
    axis (it has no azimuth)."""
    if landing_base is None or target_base is None:
        return UNKNOWN
    L = np.asarray(landing_base, dtype=float).reshape(3)
    T = np.asarray(target_base, dtype=float).reshape(3)
    reach = math.hypot(T[0], T[1])
    if not (np.isfinite(L).all() and np.isfinite(T).all() and reach > 0):
        return UNKNOWN
    ux, uy = T[0] / reach, T[1] / reach
    dx, dy, dz = L - T
    return LandingError(float(dx * ux + dy * uy), float(-dx * uy + dy * ux), float(dz))
