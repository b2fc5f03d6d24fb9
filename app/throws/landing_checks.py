"""Whether a measured training landing is plausible for its throw: checked when the rig measures
it and again before a finished run is fitted, since the progress file it waits in can be edited.

A landing is refused, in one line naming the throw and why (`implausible_landing`,
`first_implausible`), when

* it is not finite;
* it lies outside the run's training area by more than `LANDING_AREA_MARGIN_M` (the targets are
  inside the area, and a throw lands near its target);
* it lies farther than `LANDING_PREDICTION_BOUND_M` from the throw's predicted landing: the landing
  the model gives for the throw's parameters at the target's height (`forward.predict_landing`,
  the planner's own model, drag included), in 3D: its (x, z) and how far beside the throw's plane
  it came down (the model's throw stays in it).

The bounds are an order of magnitude above what the world does to a throw the model planned, so
that only a landing the throw could not have made is refused: the simulated operator's throws
(solved on the nominal model) land millimetres from their targets (`wiithrow train --sim` in the
MuJoCo world, seed 0: median 5 mm, largest 14 mm over 25 throws, with the hand's 10 ms release
latency and the manufacturing tolerances; the library's model mismatch, largest 38 mm), and a
15 ms drift of the release latency moves landings about 20 mm (`bench learning`): the prediction
bound is 0.25 m, the area's margin 0.3 m, so a landing a metre off is refused either way.
"""

from __future__ import annotations

import numpy as np

from wiithrow.app.throws.training_run import TrainingRun, TrainingThrow
from wiithrow.robot import ArmModel
from wiithrow.throwing import Area, Ball, ThrowingError, shape_for
from wiithrow.throwing.forward import predict_landing

#: How far (m) outside the run's training area a measured landing may lie (module docstring).
LANDING_AREA_MARGIN_M = 0.3
#: How far (m) from the throw's predicted landing a measured landing may lie (module docstring).
LANDING_PREDICTION_BOUND_M = 0.25


def implausible_landing(throw: TrainingThrow, area: Area, arm: ArmModel, ball: Ball) -> str | None:
    """Why `throw`'s measured landing (link1 x, z) cannot be its throw's (module docstring), as a
    clause ("its measured landing ... is ..."), or None when it is plausible."""
    if throw.measured is None or throw.params is None:
        return "it has no measured landing and parameters"
    m = np.asarray(throw.measured, dtype=float)
    shown = f"its measured landing (x {m[0]:.3f}, z {m[1]:.3f} m)" if np.isfinite(m).all() else "its measured landing"
    if not np.isfinite(m).all():
        return f"{shown} is not finite"
    (x0, x1), (z0, z1) = area.x, area.z
    outside = max(x0 - m[0], m[0] - x1, z0 - m[1], m[1] - z1, 0.0)
    if outside > LANDING_AREA_MARGIN_M:
        return (
            f"{shown} is outside the training area {area_line(area)} by more than {LANDING_AREA_MARGIN_M:g} m "
            f"({outside:.2f} m)"
        )
    try:
        predicted = predict_landing(arm, shape_for(arm), throw.params, float(throw.target[1]), ball=ball).xz
    except ThrowingError as exc:
        return f"its parameters make no landing at the target's height ({exc})"
    off = float(np.hypot(np.linalg.norm(m - predicted), throw.measured_across or 0.0))
    if not off <= LANDING_PREDICTION_BOUND_M:
        return (
            f"{shown} is {off:.2f} m from its predicted landing (at most {LANDING_PREDICTION_BOUND_M:g} m; predicted "
            f"x {predicted[0]:.3f}, z {predicted[1]:.3f} m)"
        )
    return None


def first_implausible(run: TrainingRun, arm: ArmModel, ball: Ball) -> tuple[int, str] | None:
    """The first measured throw of `run` whose landing is implausible (`implausible_landing`):
    its index and why; None when every label is plausible."""
    for i, throw in enumerate(run.throws):
        if throw.state == "measured":
            why = implausible_landing(throw, run.area, arm, ball)
            if why is not None:
                return i, why
    return None


def area_line(area: Area) -> str:
    """The area as the refusals say it: "x 1.20-1.50 m, z 0.00-0.30 m"."""
    return f"x {area.x[0]:.2f}-{area.x[1]:.2f} m, z {area.z[0]:.2f}-{area.z[1]:.2f} m"
