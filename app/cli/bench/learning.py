"""`wiithrow bench learning`: how a library that keeps learning follows a drift, and what a refit costs.

The procedure (one seeded session, through the real pipeline: the rig measures the target, joint 1
turns to it, the planner serves the throw from the learning library, the arm plays it, the rig
measures the landing marker; errors are true landings against true targets, as `bench throwing`):

1. the session with the shipped library (kinematic world) or the one `train --sim --world mujoco`
   trains (MuJoCo), learning off: `probes` throws at seeded random targets over the trained
   area, `before_drift_median_error_m`;
2. the drift: the hand lets go `DRIFT_S` (15 ms) later from now on (`world.drift`); the same
   probe targets, learning still off: `after_drift_median_error_m` (no update yet);
3. learning on: throws at other seeded targets whose measured landings join the library, 5 then
   5 more; after each 5, learning off, the probes again: `after_5_median_error_m`,
   `after_10_median_error_m`. Probes never join: each figure is the library as those joins left it.

The goal: after 10 measured throws, within 10 mm of the pre-drift median
(`recovered_within_10_mm`). In the kinematic world a 15 ms latency moves a landing by about 1 cm
(the arm's `ball` frame moves on at nearly the release velocity), so the drift's own error is
close to the goal's slack: the figures say how much of it the learning takes back.

`refit_p50_ms`, `refit_p99_ms`: the wall time of one `OnlineLibrary.add` at the size bound of 200
throws (each join retires the oldest and solves again): 200 joins timed after 200 that fill it,
the throws' parameters the regression's own at random landings with 2 mm of label noise (seeded);
`refit_cpu_*_ms` the same joins in this thread's CPU time (what a loaded, shared host's
pre-emption does not inflate), beside `load_average_1min`.
`session_refit_ms`: the joins of step 3, timed in the session.

The figures measured, and the command: docs/performance.md, "Learning".

Worlds: `kinematic` by default (about 0.6 s a throw; the MuJoCo world's throws take several
seconds each, and it trains its own library first), `--world mujoco` for the physics the planner
does not know.
"""

from __future__ import annotations

import os
import time
from collections.abc import Callable
from typing import Any, Protocol, runtime_checkable

import numpy as np
from numpy.typing import NDArray

from wiithrow.app.cli.bench.throwing import user_path_targets
from wiithrow.app.errors import AppError
from wiithrow.app.session import Session, simulated_session
from wiithrow.app.studies.compensation import random_targets, throw_at
from wiithrow.app.throws.library_file import load_library
from wiithrow.app.throws.training import train_in_world
from wiithrow.throwing import ThrowLibrary, TrainedThrow
from wiithrow.throwing.online import MAX_SIZE, OnlineLibrary

#: The drift of the hand's release latency (s): about 1 cm of a landing in the kinematic world.
DRIFT_S = 0.015
#: The recovery goal: the median error after 10 measured throws within this of the pre-drift one (m).
RECOVERY_M = 0.010
#: The refit goal at 200 throws (ms, p99).
REFIT_P99_MS = 5.0


@runtime_checkable
class Drifting(Protocol):
    """A simulated world that takes a drift (`SimWorld.drift`, `MujocoWorld.drift`)."""

    @property
    def release_latency_s(self) -> float: ...

    def drift(self, *, release_latency_s: float | None = None, ball_mass_kg: float | None = None) -> None: ...


def refit_times(library: ThrowLibrary, rng: np.random.Generator, size: int = MAX_SIZE) -> NDArray[np.float64]:
    """(size, 2): wall and this thread's CPU times (ms) of `size` joins into an `OnlineLibrary` of `library` already holding `size`
    throws (module docstring)."""
    online = OnlineLibrary.start(library, max_size=size, supersede_m=0.0)
    (x0, x1), (z0, z1) = online.area.bounds

    def one() -> tuple[float, float]:
        landing = rng.uniform((x0, z0), (x1, z1))
        params = online.predict(landing)
        throw = TrainedThrow(landing, params, landing + rng.normal(0.0, 0.002, 2))
        start, cpu = time.perf_counter(), time.thread_time()
        online.add(throw, time="bench", source="bench learning")
        return time.perf_counter() - start, time.thread_time() - cpu

    for _ in range(size):
        one()
    return 1e3 * np.array([one() for _ in range(size)])


def _probe(session: Session, targets: NDArray[np.float64]) -> NDArray[np.float64]:
    session.set_learning(False)
    return throw_at(session, targets)


def _session(world: str, quick: bool) -> tuple[Session, str]:
    say: Callable[[str], None] = lambda message: None  # noqa: E731
    if world == "kinematic":
        session = simulated_session(seed=0, quiet=True, reuse_calibration=True, say=say, library=load_library())
        return session, "the shipped library of the simulated PA-10"
    if world != "mujoco":
        raise AppError(f"unknown world {world!r}: kinematic or mujoco")
    session = simulated_session(world="mujoco", seed=0, quiet=True, reuse_calibration=True, say=say)
    targets = None if not quick else np.array([[x, z] for x in (1.0, 1.3, 1.6) for z in (0.0, 0.2, 0.4)])
    session.use_library(train_in_world(session.world, np.random.default_rng(0), targets=targets))
    return session, f"trained in the MuJoCo world ({len(session.library)} rig-labelled throws)"


def run(quick: bool = False, *, world: str = "kinematic") -> dict[str, Any]:
    probes = 6 if quick else 20
    session, library = _session(world, quick)
    rig_world = session.world
    if world == "kinematic":
        probe_targets = random_targets(probes, np.random.default_rng(1))
        learn_targets = random_targets(10, np.random.default_rng(2))
    else:
        grid = user_path_targets(session.planner.area, quick=quick)
        probe_targets = grid[: min(probes, len(grid))]
        learn_targets = random_targets(10, np.random.default_rng(2))
    if not isinstance(rig_world, Drifting):
        raise AppError(f"the {world} world takes no drift")
    before = _probe(session, probe_targets)
    latency_before = rig_world.release_latency_s
    rig_world.drift(release_latency_s=latency_before + DRIFT_S)
    after = _probe(session, probe_targets)
    joined: list[dict[str, Any]] = []
    figures: dict[str, NDArray[np.float64]] = {}
    for k in (5, 10):
        session.set_learning(True)
        for target in learn_targets[k - 5 : k]:
            throw_at(session, target[None, :])
            record = session.history[-1]
            if record.learned is not None:
                joined.append(record.learned)
        figures[f"after_{k}"] = _probe(session, probe_targets)
    rig_world.close()
    times = refit_times(load_library() if world == "kinematic" else session.library, np.random.default_rng(3))
    pre = float(np.nanmedian(before))
    after_10 = float(np.nanmedian(figures["after_10"]))
    session_ms = [float(j["refit_ms"]) for j in joined]
    return {
        "world": world,
        "library": library,
        "drift": {
            "release_latency_ms_before": 1e3 * latency_before,
            "release_latency_ms_after": 1e3 * (latency_before + DRIFT_S),
        },
        "probes": len(probe_targets),
        "before_drift_median_error_m": pre,
        "after_drift_median_error_m": float(np.nanmedian(after)),
        "after_5_median_error_m": float(np.nanmedian(figures["after_5"])),
        "after_10_median_error_m": after_10,
        "errors_m": {
            "before_drift": before.tolist(),
            "after_drift": after.tolist(),
            "after_5": figures["after_5"].tolist(),
            "after_10": figures["after_10"].tolist(),
        },
        "measured_throws_joined": len(joined),
        "library_size_after": joined[-1]["library_size"] if joined else None,
        "retired": sum(len(j["retired"]) for j in joined),
        "recovered_within_10_mm": bool(after_10 <= pre + RECOVERY_M),
        "refit_throws": MAX_SIZE,
        "refit_p50_ms": float(np.percentile(times[:, 0], 50)),
        "refit_p99_ms": float(np.percentile(times[:, 0], 99)),
        "refit_cpu_p50_ms": float(np.percentile(times[:, 1], 50)),
        "refit_cpu_p99_ms": float(np.percentile(times[:, 1], 99)),
        "load_average_1min": os.getloadavg()[0],
        "session_refit_ms": session_ms,
        "goals": {"recovery_m": RECOVERY_M, "refit_p99_ms": REFIT_P99_MS},
    }
