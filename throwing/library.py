"""The trained-throw library: 25 throws, each = parameters + the landing measured for it.

In the paper a human trains the robot: for each of 25 targets spread over the throwing area they
adjust a throw until it lands there, then the ball's landing spot is marked with an IR marker and
measured by the stereo rig. So the label of a throw is its *measured* landing, not the intended
target: calibration and execution errors are then learnt along with the throw.

`simulate_training` reproduces this in simulation: the simulated operator
(`wiithrow.throwing.operator.solve_throw`) finds each throw on the noise-free model, then the throw is
executed once with noise and measured by an injected `execute_and_measure(params, target)`
(the app's: plan, validate, play on the simulated arm, fly the ball, measure the landing marker with
the simulated stereo rig; tests use `wiithrow.throwing.simulate.SimulatedExecution`).

The training area is the arm's spec's (`arm_throwing.training_area`). The PA-10's (`TRAINING_AREA`,
in link1: x the distance from the joint-1 axis, z the height) is x 1.0-1.6 m, z 0.0-0.4 m: floor and table-top targets in front of a rig at ~0.35 m on
link1. Its far-high corner (1.6, 0.4) m needs 84 % of the E1/W1 velocity limits. The operator
(capped at 0.9 x 95 % = 85.5 % of the limits) reaches 1.71 m at 0.4 m height and 1.97 m on the
floor; the PA-10 itself (all three joints at 95 %, no drag) about 2.2 m on the floor. The area
stops short of that reach so that every trained throw is an interior optimum (a smooth function
of the target) and regressed throws keep a margin to the 95 % velocity bound.

Files: `to_dict()` / `from_dict()` with `kind` and `schema` checks; the app writes them
atomically (JSON).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from wiithrow.robot import ArmModel
from wiithrow.throwing.arm_throwing import Area, shape_for, training_area
from wiithrow.throwing.ballistics import Ball
from wiithrow.throwing.errors import LibraryFormatError, ThrowingError
from wiithrow.throwing.operator import OperatorSettings, solve_throw
from wiithrow.throwing.representation import ThrowParameters, ThrowShape
from wiithrow.throwing.throw_plane import xz

KIND = "wiithrow.throw_library"
SCHEMA = 1


#: The PA-10's training area (module docstring); another arm's is its spec's (`arm_throwing.training_area`).
TRAINING_AREA = Area((1.0, 1.6), (0.0, 0.4))


@dataclass(frozen=True)
class TrainedThrow:
    """One trained throw: `target` (x, z) the operator aimed at, `params`, and `landing` (x, z)
    the measured landing (the label), all in the throw's plane (link1 at the throw's joint-1
    angle, m); `across` (m): how far beside that plane it landed (y of that link1, + toward +y:
    the label of the sideways correction, `throwing.lateral`), None when it was not measured (a
    file from before it was kept: the key is left out)."""

    target: NDArray[np.float64]
    params: ThrowParameters
    landing: NDArray[np.float64]
    across: float | None = None

    def __post_init__(self) -> None:
        for name in ("target", "landing"):
            a = xz(getattr(self, name), f"trained throw {name}").copy()
            a.flags.writeable = False
            object.__setattr__(self, name, a)
        if not isinstance(self.params, ThrowParameters):
            raise ThrowingError(f"params must be ThrowParameters, got {type(self.params).__name__}")
        if self.across is not None:
            across = float(self.across)
            if not math.isfinite(across):
                raise ThrowingError(f"a trained throw's across offset must be finite (m), got {self.across!r}")
            object.__setattr__(self, "across", across)

    def to_dict(self) -> dict[str, object]:
        out: dict[str, object] = {
            "target": self.target.tolist(),
            "params": self.params.to_dict(),
            "landing": self.landing.tolist(),
        }
        if self.across is not None:
            out["across"] = self.across
        return out

    @classmethod
    def from_dict(cls, d: Mapping[str, Any]) -> TrainedThrow:
        """The trained throw in `d`, a JSON object (its values are checked here; no `across`: None)."""
        try:
            across = d.get("across")
            if across is not None and (isinstance(across, bool) or not isinstance(across, int | float)):
                raise TypeError(f"across must be a number, got {across!r:.40}")
            return cls(
                np.asarray(d["target"], dtype=float),
                ThrowParameters.from_dict(d["params"]),
                np.asarray(d["landing"], dtype=float),
                None if across is None else float(across),
            )
        except LibraryFormatError:
            raise
        except (KeyError, TypeError, ValueError, ThrowingError) as exc:
            raise LibraryFormatError(f"bad trained throw {d!r}: {exc}") from None


@dataclass(frozen=True)
class ThrowLibrary:
    """The trained throws of one arm with one throw shape and ball.

    `arm` (name, for `robot.load_arm`), `shape`, `ball`, `throws`, `meta` (free JSON-able notes:
    how it was trained, noise settings, ...).
    """

    arm: str
    shape: ThrowShape
    ball: Ball
    throws: tuple[TrainedThrow, ...]
    meta: dict[str, object] = field(default_factory=dict)

    def __post_init__(self) -> None:
        object.__setattr__(self, "throws", tuple(self.throws))
        if not self.throws:
            raise ThrowingError("a throw library needs at least one throw")
        n = self.shape.n
        for i, t in enumerate(self.throws):
            if t.params.q_release.size != n:
                raise ThrowingError(f"throw {i} has {t.params.q_release.size} joints, the shape {n}")

    def __len__(self) -> int:
        return len(self.throws)

    @property
    def landings(self) -> NDArray[np.float64]:
        """(N, 2) measured landings (x, z) in link1: the regression inputs."""
        return np.array([t.landing for t in self.throws])

    @property
    def across(self) -> NDArray[np.float64]:
        """(N,) measured across offsets (m, `TrainedThrow.across`), NaN where a throw has none."""
        return np.array([np.nan if t.across is None else t.across for t in self.throws], dtype=float)

    @property
    def targets(self) -> NDArray[np.float64]:
        """(N, 2) intended targets (x, z) in link1."""
        return np.array([t.target for t in self.throws])

    @property
    def parameters(self) -> NDArray[np.float64]:
        """(N, 2n) parameter vectors (ThrowParameters.vector): the regression outputs."""
        return np.array([t.params.vector for t in self.throws])

    def require_arm(self, arm: str) -> None:
        """ThrowingError unless these throws were trained for `arm`: a throw's joint angles and
        speeds mean nothing on another arm."""
        if self.arm != arm:
            raise ThrowingError(
                f"the throw library was trained for arm {self.arm!r}, and this arm is {arm!r}: train a library "
                "for this arm (`wiithrow train --sim`) or give the one trained for it (--library)"
            )

    def without(self, index: int) -> ThrowLibrary:
        """A copy without throw `index` (for leave-one-out)."""
        return ThrowLibrary(self.arm, self.shape, self.ball, self.throws[:index] + self.throws[index + 1 :], self.meta)

    def to_dict(self) -> dict[str, object]:
        return {
            "kind": KIND,
            "schema": SCHEMA,
            "arm": self.arm,
            "shape": self.shape.to_dict(),
            "ball": self.ball.to_dict(),
            "throws": [t.to_dict() for t in self.throws],
            "meta": dict(self.meta),
        }

    @classmethod
    def from_dict(cls, d: object) -> ThrowLibrary:
        """The library in `d`; LibraryFormatError if it is not a library, of another schema, or broken."""
        if not isinstance(d, dict):
            raise LibraryFormatError(f"a throw library is a JSON object, got {type(d).__name__}")
        if d.get("kind") != KIND:
            raise LibraryFormatError(f"not a throw library: kind is {d.get('kind')!r}, expected {KIND!r}")
        if d.get("schema") != SCHEMA:
            raise LibraryFormatError(
                f"throw library schema {d.get('schema')!r} is not supported (this version reads schema {SCHEMA}); "
                "retrain the library or convert it"
            )
        try:
            return cls(
                str(d["arm"]),
                ThrowShape.from_dict(d["shape"]),
                Ball.from_dict(d["ball"]),
                tuple(TrainedThrow.from_dict(t) for t in d["throws"]),
                dict(d.get("meta", {})),
            )
        except LibraryFormatError:
            raise
        except (KeyError, TypeError, ThrowingError) as exc:
            raise LibraryFormatError(f"broken throw library: {exc}") from None


def training_targets(area: Area = TRAINING_AREA, nx: int = 5, nz: int = 5) -> NDArray[np.float64]:
    """(nx nz, 2) targets (x, z) in link1 on a regular grid over `area`, corners included."""
    X, Z = np.meshgrid(np.linspace(*area.x, nx), np.linspace(*area.z, nz), indexing="ij")
    return np.column_stack([X.ravel(), Z.ravel()])


ExecuteAndMeasure = Callable[[ThrowParameters, NDArray[np.float64]], Iterable[float]]


def simulate_training(
    arm: ArmModel,
    targets: ArrayLike | None,
    execute_and_measure: ExecuteAndMeasure,
    rng: np.random.Generator,
    *,
    shape: ThrowShape | None = None,
    ball: Ball | None = None,
    operator: OperatorSettings | None = None,
    placement_jitter: float = 0.01,
    meta: dict[str, object] | None = None,
) -> ThrowLibrary:
    """The simulated operator's manual training (module docstring).

    `targets` (N, 2) (x, z) in link1, or None for the 5 x 5 grid over the arm's training area
    (`arm_throwing.training_area`; the PA-10's is TRAINING_AREA); `shape` defaults to the arm's. Each is
    displaced by N(0, placement_jitter^2) in x (the operator sets the markers by hand; heights are
    the surfaces'), drawn from `rng`. For each: the operator solves the throw on the noise-free
    model, then `execute_and_measure(params, target)` executes it once and returns the measured
    landing in the throw's plane, the label: (x, z), or (x, y, z) with y its across offset (link1 y
    at the throw's joint-1 angle, `TrainedThrow.across`). Raises UnreachableTargetError if a target
    is out of range.
    """
    if not isinstance(rng, np.random.Generator):
        raise ThrowingError("simulate_training needs an explicit numpy.random.Generator")
    shape = shape or shape_for(arm)
    ball = ball or Ball()
    T = training_targets(training_area(arm)) if targets is None else np.asarray(targets, dtype=float)
    if T.ndim != 2 or T.shape[1] != 2:
        raise ThrowingError(f"targets must have shape (N, 2), got {T.shape}")
    throws = []
    for target in T:
        tgt = target + np.array([rng.normal(0.0, placement_jitter) if placement_jitter > 0 else 0.0, 0.0])
        params = solve_throw(arm, tgt, shape=shape, ball=ball, settings=operator)
        landed = np.asarray(list(execute_and_measure(params, tgt)), dtype=float)
        across = float(landed[1]) if landed.shape == (3,) else None
        measured = xz(landed[[0, 2]] if landed.shape == (3,) else landed, "measured landing")
        throws.append(TrainedThrow(tgt, params, measured, across))
    info = {
        "trained_by": "simulate_training",
        "placement_jitter": placement_jitter,
        "targets": len(throws),
        **(meta or {}),
    }
    return ThrowLibrary(arm.name, shape, ball, tuple(throws), info)
