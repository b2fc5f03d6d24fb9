"""How far an arm's throw can land at most: the bound a target is checked against before anything
plans or moves for it (a target of 1e300 m, or a NaN, is one line, not an overflow in the planner).

The bound is loose on purpose: it needs no search (the simulated operator's solves that bound the
training area, `reachable_area`, take seconds) and no arm can beat it. With

    L = the sum of the distances between consecutive joint origins from joint 1 to the `ball`
        frame (no configuration puts the ball farther than L from joint 1's origin),
    z1 = the height of joint 1's origin above base,
    v = L * sum_i qd_max_i over the joints a throw moves (its spec's throwing joints; every joint
        of an arm that does not throw): each moves the ball at most qd_max_i times its distance
        from the axis, itself at most L: the release speed's bound,

the ball is released at most z1 + L above base and L from joint 1's axis, rises at most v^2 / 2g
above its release, and a ball released H above its landing surface at speed v flies at most
(v / g) sqrt(v^2 + 2 g H) <= v^2 / g + H horizontally (no drag; drag only shortens it). So a target
at height z in base, at distance d from joint 1's axis, is reachable only if

    z <= z1 + L + v^2 / (2 g)         and       d <= L + v^2 / g + (z1 + L - z),

and the floor under a target is at most `z1 + L` below base (no lab mounts an arm higher above its
floor than the arm is tall): z >= -(z1 + L). For the PA-10: L = 1.47 m, v = 13.6 m/s (S2, E1 and
W1 at 1, 2 and 6.3 rad/s), a target on the floor is beyond it past 21.8 m (its operator reaches
2 m).
"""

from __future__ import annotations

import math
import weakref
from dataclasses import dataclass

import numpy as np

from wiithrow.robot import ArmModel
from wiithrow.throwing.ballistics import GRAVITY as G
from wiithrow.throwing.errors import UnreachableTargetError


@dataclass(frozen=True)
class ThrowReach:
    """An arm's throw bound (module docstring): `length_m` L, `shoulder_m` z1, `speed_m_s` v."""

    length_m: float
    shoulder_m: float
    speed_m_s: float

    @property
    def highest_m(self) -> float:
        """The highest a ball can land (m, in base)."""
        return self.shoulder_m + self.length_m + self.speed_m_s**2 / (2 * G)

    @property
    def lowest_m(self) -> float:
        """The lowest a target may be (m, in base): the floor at most the arm's height below base."""
        return -(self.shoulder_m + self.length_m)

    def farthest_m(self, height_m: float) -> float:
        """The farthest from joint 1's axis a ball can land at `height_m` (m)."""
        drop = self.shoulder_m + self.length_m - height_m
        return self.length_m + self.speed_m_s**2 / G + max(drop, 0.0)


_REACH: weakref.WeakKeyDictionary[ArmModel, ThrowReach] = weakref.WeakKeyDictionary()


def throw_reach(arm: ArmModel) -> ThrowReach:
    """The bound of `arm`'s throws (module docstring), computed once per model."""
    reach = _REACH.get(arm)
    if reach is None:
        model = arm.model
        length = sum(float(np.linalg.norm(model.jointPlacements[j].translation)) for j in range(2, model.njoints))
        ball = model.frames[model.getFrameId("ball")]  # its placement is relative to its joint (pinocchio's)
        length += float(np.linalg.norm(ball.placement.translation))
        shoulder = float(model.jointPlacements[1].translation[2])
        spec = arm.spec.throwing if arm.spec is not None else None
        moving = [arm.joint_names.index(j) for j in spec.joints] if spec is not None else range(arm.nq)
        speed = length * float(np.sum(arm.velocity_limit[list(moving)]))
        reach = ThrowReach(length, shoulder, speed)
        _REACH[arm] = reach
    return reach


def check_target_reach(arm: ArmModel, target_base: np.ndarray | tuple[float, ...], what: str = "the target") -> None:
    """UnreachableTargetError, one line, for a target (x, y, z) in base (m) that is not finite or
    that no throw of `arm` can reach (module docstring)."""
    x, y, z = (float(v) for v in np.asarray(target_base, dtype=float).reshape(3))
    shown = f"({x:g}, {y:g}, {z:g}) m in base"
    if not all(math.isfinite(v) for v in (x, y, z)):
        raise UnreachableTargetError(f"{what} {shown} is not a position: every coordinate must be a finite number")
    check_throw_plane_reach(arm, math.hypot(x, y), z, f"{what} {shown}")


def check_throw_plane_reach(arm: ArmModel, distance_m: float, height_m: float, what: str) -> None:
    """UnreachableTargetError "WHAT is beyond the reach of arm A: ..." for a point of the throw
    plane (distance from joint 1's axis, height; m) that no throw of `arm` can reach."""
    reach = throw_reach(arm)
    if not (math.isfinite(distance_m) and math.isfinite(height_m)):
        raise UnreachableTargetError(f"{what} is not a position: every coordinate must be a finite number")
    if not reach.lowest_m <= height_m <= reach.highest_m:
        raise UnreachableTargetError(
            f"{what} is beyond the reach of arm {arm.name}: its throws land between heights {reach.lowest_m:.1f} "
            f"and {reach.highest_m:.1f} m in base"
        )
    farthest = reach.farthest_m(height_m)
    if distance_m > farthest:
        raise UnreachableTargetError(
            f"{what} is beyond the reach of arm {arm.name}: {distance_m:.3g} m from joint 1's axis, and its throws "
            f"land at most {farthest:.1f} m from it at that height"
        )
