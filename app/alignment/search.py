"""Where joint 1 goes to look for a target that no camera sees: a doubling sweep."""

from __future__ import annotations


def sweep_waypoints(q0: float, lower: float, upper: float, step: float) -> list[float]:
    """Joint-1 targets of the search: q0 + step, q0 - 2 step, q0 + 4 step, ... (a doubling sweep:
    it never travels more than about 9 times the distance to the target), clipped to the limits;
    a side whose limit was reached is not visited again. Ends when both limits are reached."""
    points: list[float] = []
    at_upper = at_lower = False
    amplitude, sign = step, 1.0
    while not (at_upper and at_lower):
        if sign > 0 and not at_upper:
            points.append(min(q0 + amplitude, upper))
            at_upper = points[-1] >= upper
        elif sign < 0 and not at_lower:
            points.append(max(q0 - amplitude, lower))
            at_lower = points[-1] <= lower
        amplitude, sign = 2.0 * amplitude, -sign
    return points
