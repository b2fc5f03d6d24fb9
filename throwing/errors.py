"""The exceptions of the throwing package: each says what was wrong and what to do about it.

All derive from `ThrowingError`, itself a `ValueError`, so a caller (the app) can catch every
expected failure of this package with one clause; `robot.RobotError` (bad joint vectors, Ruckig
refusals) is also a `ValueError`.
"""

from __future__ import annotations

from collections.abc import Iterable
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from wiithrow.throwing.validator import ValidationReport


class ThrowingError(ValueError):
    """Base class of every expected failure in `throwing` (bad settings, shapes, files, targets)."""


class NoLandingError(ThrowingError):
    """The ball never comes down through the requested height (its apex is below it, or it starts
    below it moving down)."""


class UnreachableTargetError(ThrowingError):
    """No throw within the arm's limits reaches the target (inverse ballistics or the operator)."""


class InfeasibleThrowError(ThrowingError):
    """Throw parameters outside what the representation guarantees to be executable (a release
    velocity above its margin, a pose outside the position limits, a reference above a limit)."""


class OutsideTrainedAreaError(ThrowingError):
    """A target outside the trained area (the convex hull of the library's measured landings).

    Attributes: `target` (x, z) in link1 (m), `distance` (m) outside the area, `margin` (m) allowed.
    """

    def __init__(self, message: str, target: Iterable[float], distance: float, margin: float) -> None:
        super().__init__(message)
        self.target = tuple(float(v) for v in target)
        self.distance = float(distance)
        self.margin = float(margin)


class TrajectoryRejected(ThrowingError):
    """The independent validator found limit or floor violations; `report` holds all of them."""

    def __init__(self, message: str, report: ValidationReport | None = None) -> None:
        super().__init__(message)
        self.report = report


class LibraryFormatError(ThrowingError):
    """A library (or settings) dictionary of the wrong kind, schema version or content."""
