"""`wiithrow bench throwing`: landing accuracy, repeatability and planning time of the whole system.

Everything runs in the simulated world through the real pipeline: the robot-calibrated rig
measures a seeded random target, joint 1 turns it into the throw plane, the shipped library's
Gaussian process gives the throw, the planner makes and validates the trajectory, the simulated
arm plays it with its noise (joint tracking error, release jitter), the ball flies with drag, and
the error is the true landing against the true target.

Figures (JSON keys): `median_error_m`, `p95_error_m` over random targets inside the trained area
with noise on; `repeatability_m` (RMS distance of 20 landings at one target from their mean) and
`repeatability_max_m`; `generalization_error_m` (median error with every noise off: what the
regression itself misses); `plan_p50_ms`, `plan_p99_ms`: target -> validated throw trajectory
(wind-up, release, braking); `plan_with_approach_p50_ms`, `..._p99_ms`: the same with the approach
move from the arm's current pose prepended, as the session plans it (the validator then checks
about three times as many samples). Goals: median <= 2 cm, p95 <= 5 cm, repeatability <= 2 cm,
p99 planning <= 5 ms.
"""

from __future__ import annotations

import time

import numpy as np
from numpy.typing import NDArray

from wiithrow.app.session import Session, simulated_session
from wiithrow.app.settings import NoiseSettings, Settings
from wiithrow.app.studies.compensation import random_targets, throw_at
from wiithrow.app.throws.execution import planning_start


def _repeatability(session: Session, target: NDArray[np.float64], count: int) -> tuple[float, float]:
    """RMS and largest distance (m) of `count` landings at one target from their mean."""
    session.set_target(target)
    session.align()
    landings = np.array([session.throw(session.plan_preview().id).execution.landing_base for _ in range(count)])
    d = np.linalg.norm(landings - landings.mean(axis=0), axis=1)
    return float(np.sqrt(np.mean(d**2))), float(d.max())


def _plan_times(session: Session, targets_xz: NDArray[np.float64], *, approach: bool) -> NDArray[np.float64]:
    q = planning_start(session.world)
    q_start = q if approach else None
    planner = session.planner
    planner.plan(targets_xz[0], q1=q[0], q_start=q_start)  # warm-up
    times = []
    for target in targets_xz:
        start = time.perf_counter()
        planner.plan(target, q1=q[0], q_start=q_start)
        times.append(time.perf_counter() - start)
    return 1e3 * np.array(times)


def run(quick: bool = False) -> dict:
    n = 4 if quick else 200
    repeats = 3 if quick else 20
    session = simulated_session(seed=0, quiet=True)
    targets = random_targets(n, np.random.default_rng(1))
    errors = throw_at(session, targets)
    rep_rms, rep_max = _repeatability(session, targets[0], repeats)

    exact = Settings().replace(noise=NoiseSettings(pixel_sigma_px=0.0, release_jitter_s=0.0, joint_tracking_rad=0.0))
    quiet_session = simulated_session(seed=0, settings=exact, quiet=True)
    clean = throw_at(quiet_session, targets[: max(4, n // 4)])

    xz = np.column_stack([np.hypot(targets[:, 0], targets[:, 1]), targets[:, 2]])
    plan_ms = _plan_times(session, xz, approach=False)
    approach_ms = _plan_times(session, xz, approach=True)
    return {
        "targets": n,
        "failed_throws": int(np.isnan(errors).sum()),
        "median_error_m": float(np.nanmedian(errors)),
        "p95_error_m": float(np.nanpercentile(errors, 95)),
        "max_error_m": float(np.nanmax(errors)),
        "repeatability_m": rep_rms,
        "repeatability_max_m": rep_max,
        "repeat_throws": repeats,
        "generalization_error_m": float(np.nanmedian(clean)),
        "plan_p50_ms": float(np.percentile(plan_ms, 50)),
        "plan_p99_ms": float(np.percentile(plan_ms, 99)),
        "plan_with_approach_p50_ms": float(np.percentile(approach_ms, 50)),
        "plan_with_approach_p99_ms": float(np.percentile(approach_ms, 99)),
        "paper_accuracy_m": [0.02, 0.10],
        "paper_repeatability_m": [0.02, 0.03],
    }
