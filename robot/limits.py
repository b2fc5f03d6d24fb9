"""Joint limits of an arm: position, velocity, acceleration and jerk, one value per joint.

`JointLimits` is what trajectory planning and the simulated arm need of an arm; `ArmModel.limits`
gives one (an ArmModel is a `HasJointLimits`), and a caller may build one by hand (e.g. scaled-down
limits for a careful move).
Velocity, acceleration and jerk limits are symmetric: |dq| <= velocity, and so on.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Protocol

import numpy as np
from numpy.typing import ArrayLike, NDArray

from wiithrow.robot.errors import LimitError, RobotError


def _vector(name: str, values: ArrayLike, n: int | None = None) -> NDArray[np.float64]:
    """A read-only float vector of length n (a scalar is repeated), or a RobotError saying what was wrong."""
    a = np.array(values, dtype=float)
    if a.ndim == 0 and n is not None:
        a = np.full(n, float(a))
    if n is not None and a.shape != (n,):
        raise RobotError(f"{name} must have {n} values (one per joint), got shape {np.shape(values)}")
    if not np.all(np.isfinite(a)):
        raise RobotError(f"{name} must be finite, got {a}")
    a.flags.writeable = False
    return a


class HasJointLimits(Protocol):
    """Anything that carries joint limits (an `ArmModel`): trajectory planning takes it or the limits."""

    @property
    def limits(self) -> JointLimits: ...


@dataclass(frozen=True)
class JointLimits:
    """Per-joint limits, SI units: rad, rad/s, rad/s^2, rad/s^3."""

    names: tuple[str, ...]
    lower: NDArray[np.float64]
    upper: NDArray[np.float64]
    velocity: NDArray[np.float64]
    acceleration: NDArray[np.float64]
    jerk: NDArray[np.float64]

    def __post_init__(self) -> None:
        n = len(self.names)
        object.__setattr__(self, "names", tuple(self.names))
        for field in ("lower", "upper", "velocity", "acceleration", "jerk"):
            object.__setattr__(self, field, _vector(field, getattr(self, field), n))
        if np.any(self.lower > self.upper):
            j = int(np.argmax(self.lower > self.upper))
            raise RobotError(f"joint {self.names[j]}: lower position limit {self.lower[j]} > upper {self.upper[j]}")
        for field in ("velocity", "acceleration", "jerk"):
            v = getattr(self, field)
            if np.any(v <= 0):
                j = int(np.argmax(v <= 0))
                raise RobotError(f"joint {self.names[j]}: {field} limit must be > 0, got {v[j]}")

    @property
    def n(self) -> int:
        """Number of joints."""
        return len(self.names)

    def vector(self, q: ArrayLike, what: str = "q") -> NDArray[np.float64]:
        """`q` as a float vector of length n (a copy), or a RobotError naming `what`."""
        a = np.asarray(q, dtype=float)
        if a.shape != (self.n,):
            raise RobotError(f"{what} must have shape ({self.n},) (joints {', '.join(self.names)}), got {a.shape}")
        if not np.isfinite(a).all():  # (the method: np.all's Python wrapper costs as much again; this runs per FK)
            raise RobotError(f"{what} must be finite, got {a}")
        return a.copy()

    def within(self, q: ArrayLike, tol: float = 1e-9) -> bool:
        """True if every joint of `q` is inside [lower - tol, upper + tol]."""
        a = self.vector(q)
        return bool(np.all(a >= self.lower - tol) and np.all(a <= self.upper + tol))

    def clip(self, q: ArrayLike) -> NDArray[np.float64]:
        """`q` clamped into the position limits."""
        clipped: NDArray[np.float64] = np.clip(self.vector(q), self.lower, self.upper)
        return clipped

    def check_position(self, q: ArrayLike, what: str = "q", tol: float = 1e-9) -> NDArray[np.float64]:
        """Return `q` as a vector if inside the position limits, else raise LimitError naming the joint."""
        a = self.vector(q, what)
        bad = (a < self.lower - tol) | (a > self.upper + tol)
        if np.any(bad):
            j = int(np.argmax(bad))
            raise LimitError(
                f"{what}: joint {self.names[j]} = {a[j]:.4f} rad ({np.degrees(a[j]):.1f} deg) is outside its "
                f"limits [{self.lower[j]:.4f}, {self.upper[j]:.4f}] rad; choose a position inside them",
                joint=self.names[j],
            )
        return a

    def check_bound(
        self, values: ArrayLike, bound: NDArray[np.float64], quantity: str, what: str, tol: float = 1e-9
    ) -> None:
        """Raise LimitError if any |values[..., j]| exceeds bound[j] (1 + tol relative); `values` is (n,) or (T, n)."""
        a = np.abs(np.asarray(values, dtype=float))
        bad = a > bound * (1.0 + tol) + tol
        if np.any(bad):
            idx = np.argwhere(bad)[0]
            j = int(idx[-1])
            at = f" at sample {int(idx[0])}" if a.ndim == 2 else ""
            raise LimitError(
                f"{what}: joint {self.names[j]} {quantity} {a[tuple(idx)]:.4f}{at} exceeds its limit {bound[j]:.4f}",
                joint=self.names[j],
            )

    def scaled(self, velocity: float = 1.0, acceleration: float = 1.0, jerk: float = 1.0) -> JointLimits:
        """A copy with the velocity, acceleration and jerk limits multiplied by the given factors (0, 1]."""
        for k, f in (("velocity", velocity), ("acceleration", acceleration), ("jerk", jerk)):
            if not 0 < f <= 1:
                raise RobotError(f"{k} scale must be in (0, 1], got {f}")
        return JointLimits(
            self.names,
            self.lower,
            self.upper,
            self.velocity * velocity,
            self.acceleration * acceleration,
            self.jerk * jerk,
        )
