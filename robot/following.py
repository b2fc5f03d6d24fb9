"""A command's exact following by `SimulatedArm`, computed once for the whole command (the
arm's `ideal_path` serves the reference of many servo periods as slices of it).

`SimulatedArm._step` follows its command exactly when the step it asks for is feasible: at step
s of the command, with r_s the command's reference there (`SimulatedArm._reference`: the sample
itself on the samples' grid, else `JointTrajectory.sample`) and (q, v) the servo's state,

    q <- r_s,   v_s = (r_s - q) / dt,   a_s = (v_s - v) / dt,
    if |v_s| <= v_max (1 + 1e-9), |a_s| <= a_max (1 + 1e-6) and r_s within the position limits.

A servo that followed exactly since step 1 has q = r_{s-1} and v = v_{s-1}, so its steps depend on
the command alone: v_s = (r_s - r_{s-1}) / dt (s >= 2), a_s = (v_s - v_{s-1}) / dt (s >= 3). This
module owns that table and the test of a step's exactness; `SimulatedArm` decides when the servo
is on it (`robot/simulated.py`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from wiithrow.robot.limits import JointLimits
from wiithrow.robot.trajectory import JointTrajectory


@dataclass(frozen=True)
class FollowTable:
    """A command's exact following (module docstring) at its steps s = 1..`steps` (s steps after
    it started, `offset` s after its first sample's time at the step it was given): `q[s]` the
    reference r_s, `v[s]` (s >= 2) and `a[s]` (s >= 3) a servo's on it; `next_bad[s]`: the first
    step >= s the table cannot give (`_step` would limit it, or s < 3, or s > steps). `ends`: the
    command ends at its last step (else, ending in motion, it goes on into a brake then)."""

    traj: JointTrajectory
    offset: float
    steps: int
    ends: bool
    q: NDArray[np.float64]
    v: NDArray[np.float64]
    a: NDArray[np.float64]
    next_bad: NDArray[np.int64]


def exact_rows(
    q: NDArray[np.float64], v: NDArray[np.float64], a: NDArray[np.float64], limits: JointLimits
) -> NDArray[np.bool_]:
    """Per row (a step): followed exactly, velocity and acceleration within the limits with
    `SimulatedArm._step`'s tolerances, the position within its limits."""
    ok = (np.abs(v) <= limits.velocity * (1 + 1e-9)) & (np.abs(a) <= limits.acceleration * (1 + 1e-6))
    return np.asarray((ok & (q >= limits.lower) & (q <= limits.upper)).all(axis=1))


def follow_table(traj: JointTrajectory, offset: float, moving_end: bool, dt: float, limits: JointLimits) -> FollowTable:
    """The `FollowTable` of `traj` commanded `offset` s into it, ending in motion or not, at
    servo period `dt`: its steps up to the one that ends it (or, ending in motion, up to the last
    one before its end's time, after which `SimulatedArm` brakes)."""
    duration = traj.duration
    count = math.ceil((duration - offset) / dt + 1e-9) + 2  # past the command's end
    rel = offset + np.arange(1, count + 1) * dt  # the command's time at steps 1, 2, ... (as `_reference`)
    if moving_end:
        steps = int(np.searchsorted(rel, duration + 1e-9, side="right"))
    else:
        steps = int(np.searchsorted(rel, duration - 1e-9, side="left")) + 1
    rel = rel[:steps]
    q = np.full((steps + 1, traj.nq), np.nan)
    on_sample = np.zeros(steps, dtype=bool)
    if offset == 0.0:  # a step on a sample takes it, no interpolation
        index = np.arange(1, steps + 1)
        inside = index < traj.times.size
        on_sample[inside] = np.abs(traj.times[index[inside]] - traj.times[0] - rel[inside]) < 1e-9
        q[1:][on_sample] = traj.positions[index[on_sample]]
    if not on_sample.all():
        q[1:][~on_sample] = traj.sample(traj.times[0] + rel[~on_sample])[0]
    v = np.full_like(q, np.nan)
    v[2:] = (q[2:] - q[1:-1]) / dt
    a = np.full_like(q, np.nan)
    a[3:] = (v[3:] - v[2:-1]) / dt
    ok = np.zeros(steps + 2, dtype=bool)  # steps 0-2 and past the end: not in the table
    ok[3 : steps + 1] = exact_rows(q[3:], v[3:], a[3:], limits)
    bad = np.where(~ok, np.arange(steps + 2), steps + 1)
    next_bad = np.minimum.accumulate(bad[::-1])[::-1]
    return FollowTable(traj, offset, steps, not moving_end, q, v, a, next_bad)
