"""`wiithrow bench throwing`: landing accuracy, repeatability and planning time of the whole system.

Everything runs through the real pipeline: the robot-calibrated rig measures a seeded random
target, joint 1 turns it into the throw plane, the library's Gaussian process gives the throw, the
planner makes and validates the trajectory, the arm plays it, the hand lets go, and the error is
the true landing against the true target (the simulation knows both).

Two worlds (`world`):

* `mujoco` (default): the MuJoCo world (`wiithrow.app.worlds.mujoco`), physics the planner does not
  know: the arm through its dynamics and a velocity-mode servo, manufacturing tolerances, the hand's
  latency and jitter, the ball's spin and MuJoCo's fluid model, touchdown on the ball's surface.
  It measures the user's path, through the sessions and functions the commands use: the session
  `wiithrow train --sim --world mujoco` makes (the simulated rig's robot calibration,
  `wiithrow.app.calibration.simulated`, kept and reused while valid as the commands do), its 25
  throws labelled by the rig's measurement of the marker the simulated operator puts where the
  ball came down (`train_in_world`, seeded as `train --seed 0`), then, per target, a fresh session
  as `wiithrow throw --sim --world mujoco --library ... --yes` makes one, thrown at once. The
  targets cover the trained area (a grid of distances and heights inside the hull of the measured
  landings, at azimuths -0.3, 0, 0.3 rad), the demo's target (`DEMO_TARGET_XZ`) first. The same
  targets are then thrown at once more without the learning (`analytic_median_error_m`:
  `throwing.AnalyticPlanner`, the nominal model's exact solution): what the learning is for.
  Every session here is made with `learn=False`: the figures are the trained library's, not a library
  that learnt from the benchmark's own targets (`bench learning` measures that).
  `release_latency_ms`, `release_jitter_ms`, `placement_sigma_mm` and `kinematic_error_mm`
  (link-length tolerance; joint zero offsets 2 mrad per mm) set the world.
* `kinematic`: the `SimWorld`, whose arm and ball are the planner's own models, with the shipped
  library (what the project measured before MuJoCo), at seeded random targets.
* `--settings S.json`: the hardware path, through the drivers the settings name, every landing
  measured by the rig (`wiithrow.app.cli.bench.throwing_hardware`).

Figures (JSON keys): `median_error_m`, `p95_error_m`, `max_error_m` (true errors), `errors_m` and
`target_list_base_m` (MuJoCo), `demo_target_error_m`; `calibration_ratio`: the robot calibration's
median 3D error over the trained area against the true cameras' on the same pixels
(`wiithrow.app.calibration.truth`; details in `calibration_area_error`), `calibration_kinematics`
(identified or nominal), `calibration_loo_m`; `repeatability_m` (RMS distance of 20 landings at
the demo's target, thrown one after the other in one session, from their mean) and
`repeatability_max_m`; `analytic_median_error_m`, `analytic_p95_error_m`;
`release_tracking_error_mm` (median distance of the `ball` frame, by the nominal kinematics of the
measured joints, from the plan's release position when the hand is told to open: the servo's
lag); `real_time_factor` (simulated seconds of the repeated throws over the CPU seconds this
thread spent on them: one core, headless); `generalization_error_m` (kinematic world: median error
with every noise off); `plan_p50_ms`, `plan_p99_ms`: target -> validated throw trajectory;
`plan_with_approach_*`: the same with the approach move from the arm's current pose prepended, as
the session plans it.
Goals (MuJoCo, `GOALS`): median <= 15 mm, p95 <= 30 mm, the demo's target within 15 mm,
calibration ratio <= 1.5, repeatability <= 15 mm, real-time factor >= 30 (one core, headless);
(kinematic): median
<= 2 cm, p95 <= 5 cm.
"""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Callable
from typing import Any

import numpy as np
from numpy.typing import NDArray

from wiithrow.app.calibration.truth import area_error, area_points
from wiithrow.app.errors import AppError
from wiithrow.app.session import DEFAULT_MARGIN_M, Session, simulated_session
from wiithrow.app.session.simulated import demo_target_base
from wiithrow.app.settings import NoiseSettings, Settings
from wiithrow.app.studies.compensation import random_targets, throw_at
from wiithrow.app.throws.execution import planning_start
from wiithrow.app.throws.training import train_in_world
from wiithrow.throwing import TrainedArea

#: The goals of the MuJoCo user's path: true errors, the demo's target, the robot
#: calibration's 3D error over the trained area relative to the true cameras'.
GOALS = {
    "median_m": 0.015,
    "p95_m": 0.03,
    "demo_target_m": 0.015,
    "calibration_ratio": 1.5,
    "repeatability_m": 0.015,
    "real_time_factor": 30.0,  # one core, headless
}

#: Joint zero offsets per millimetre of link-length tolerance (the defaults: 1 mm, 2 mrad).
OFFSET_RAD_PER_MM = 0.002


def mujoco_settings(
    *,
    release_latency_ms: float | None = None,
    release_jitter_ms: float | None = None,
    placement_sigma_mm: float | None = None,
    kinematic_error_mm: float | None = None,
) -> Settings:
    """The default settings with the benchmark's world flags applied (None: the default)."""
    mj = Settings().mujoco
    changes: dict[str, Any] = {}
    for key, value, scale in (
        ("release_latency_s", release_latency_ms, 1e-3),
        ("release_jitter_s", release_jitter_ms, 1e-3),
        ("placement_sigma_m", placement_sigma_mm, 1e-3),
    ):
        if value is not None:
            if not (np.isfinite(value) and value >= 0):
                raise AppError(
                    f"--{key.replace('_s', '').replace('_m', '').replace('_', '-')} must be >= 0, got {value}"
                )
            changes[key] = value * scale
    if kinematic_error_mm is not None:
        if not (np.isfinite(kinematic_error_mm) and kinematic_error_mm >= 0):
            raise AppError(f"--kinematic-error-mm must be >= 0, got {kinematic_error_mm}")
        changes["link_length_sigma_m"] = 1e-3 * kinematic_error_mm
        changes["joint_offset_sigma_rad"] = OFFSET_RAD_PER_MM * kinematic_error_mm
    return Settings().replace(mujoco=dataclasses.replace(mj, **changes))


def _repeatability(session: Session, target: NDArray[np.float64], count: int) -> tuple[float, float, float]:
    """RMS and largest distance (m) of `count` landings at one target from their mean, and the
    real-time factor of those throws (simulated over thread CPU seconds)."""
    session.set_target(target)
    session.align()
    landings, simulated, cpu = [], 0.0, 0.0
    for _ in range(count):
        preview = session.plan_preview()
        t0, c0 = session.world.clock.now(), time.thread_time()
        landings.append(session.throw(preview.id).execution.landing_base)
        simulated += session.world.clock.now() - t0
        cpu += time.thread_time() - c0
    points = np.array(landings)
    d = np.linalg.norm(points - points.mean(axis=0), axis=1)
    return float(np.sqrt(np.mean(d**2))), float(d.max()), simulated / max(cpu, 1e-9)


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


def _summary(errors: NDArray[np.float64], prefix: str = "") -> dict[str, float]:
    return {
        f"{prefix}median_error_m": float(np.nanmedian(errors)),
        f"{prefix}p95_error_m": float(np.nanpercentile(errors, 95)),
        f"{prefix}max_error_m": float(np.nanmax(errors)),
    }


def run(
    quick: bool = False,
    *,
    world: str = "mujoco",
    release_latency_ms: float | None = None,
    release_jitter_ms: float | None = None,
    placement_sigma_mm: float | None = None,
    kinematic_error_mm: float | None = None,
    settings_file: str | None = None,
    sim_clock: bool = False,
) -> dict[str, Any]:
    if settings_file is not None:  # the hardware path: the drivers the settings name, rig-measured landings only
        if world != "mujoco" or any(f is not None for f in (release_latency_ms, release_jitter_ms, placement_sigma_mm)):
            raise AppError(
                "--settings names the drivers (and their world's settings): --world and the world flags do not apply"
            )
        from wiithrow.app.cli.bench.throwing_hardware import run as run_on_hardware

        return run_on_hardware(settings_file, quick=quick, sim_clock=sim_clock)
    n = 4 if quick else 200
    repeats = 3 if quick else 20
    flags = (release_latency_ms, release_jitter_ms, placement_sigma_mm, kinematic_error_mm)
    if world == "kinematic":
        if any(f is not None for f in flags):
            raise AppError(
                "--release-latency-ms, --release-jitter-ms, --placement-sigma-mm and --kinematic-error-mm set the MuJoCo world (--world mujoco)"
            )
        return _kinematic(random_targets(n, np.random.default_rng(1)), repeats, n)
    if world != "mujoco":
        raise AppError(f"unknown world {world!r}: mujoco or kinematic")
    settings = mujoco_settings(
        release_latency_ms=release_latency_ms,
        release_jitter_ms=release_jitter_ms,
        placement_sigma_mm=placement_sigma_mm,
        kinematic_error_mm=kinematic_error_mm,
    )
    return _mujoco_user_path(settings, quick=quick, repeats=repeats)


def user_path_targets(area: TrainedArea, *, quick: bool = False) -> NDArray[np.float64]:
    """Targets in base over the whole trained area: the demo's first, then a grid of distances
    and heights at azimuths that change from one to the next; those the trained area (the hull
    of the measured landings) does not hold are left out, as `throw` refuses them."""
    (x0, x1), (z0, z1) = area.bounds
    xs = np.linspace(x0 + 0.04, x1 - 0.04, 3 if quick else 5)
    zs = np.linspace(z0 + 0.04, z1 - 0.04, 2 if quick else 4)
    azimuths = (-0.3, 0.0, 0.3)
    grid = [(x, z) for x in xs for z in zs if area.contains((x, z))]
    targets = [demo_target_base()]
    for k, (x, z) in enumerate(grid):
        psi = azimuths[k % len(azimuths)]
        targets.append(np.array([x * np.cos(psi), x * np.sin(psi), z]))
    return np.array(targets)


def _throw_like_the_command(session: Session, target: NDArray[np.float64]) -> float:
    """What `wiithrow throw --sim --target ... --yes` does once its session exists: the target,
    joint 1 aligned, the preview planned within the command's margin, thrown; the true error (m),
    NaN when joint 1 could not be aligned."""
    session.margin_m = DEFAULT_MARGIN_M
    session.set_target(target)
    if not session.align().converged:
        return float("nan")
    preview = session.plan_preview(margin_m=DEFAULT_MARGIN_M)
    error = session.throw(preview.id).true_error_m
    return float("nan") if error is None else float(error)


def _mujoco_user_path(settings: Settings, *, quick: bool, repeats: int) -> dict[str, Any]:
    """The user's path (module docstring): the session `train --sim --world mujoco` makes (the
    simulated rig's robot calibration, kept and reused while valid, as the commands do), its 25
    rig-labelled throws (`train_in_world`, seeded as `train --seed 0`), then a fresh session per
    target as `throw --sim --world mujoco --library ... --yes` makes one, thrown at once."""
    seed = 0
    say: Callable[[str], None] = lambda message: None  # noqa: E731
    trainer = simulated_session(
        world="mujoco", seed=seed, settings=settings, calibration="robot", reuse_calibration=True, say=say, quiet=True
    )
    library = train_in_world(trainer.world, np.random.default_rng(seed))
    trainer.use_library(library)
    area = trainer.planner.area
    calibration = trainer.world.calibration
    assert calibration is not None  # calibrated with the robot above
    inside = area_points(np.random.default_rng(2), 6000, *area.bounds)
    inside = inside[[area.contains((p[0], p[2])) for p in inside]]
    calibration_error = area_error(trainer.world, calibration, np.random.default_rng(3), inside)
    kinematics = calibration.meta.get("kinematics", {})
    trainer.world.close()

    def throw_session() -> Session:
        """A session as `throw --sim --world mujoco --library ...` makes one (the kept calibration)."""
        return simulated_session(
            world="mujoco",
            seed=seed,
            settings=settings,
            calibration="robot",
            library=library,
            reuse_calibration=True,
            say=say,
            quiet=True,
            learn=False,
        )

    targets = user_path_targets(area, quick=quick)
    errors = []
    tracking: list[float] = []
    for target in targets:
        session = throw_session()
        errors.append(_throw_like_the_command(session, target))
        if session.history:
            tracking.append(session.history[-1].execution.release_tracking_m)
        session.world.close()
    errors_m = np.array(errors)

    session = throw_session()
    rep_rms, rep_max, rtf = _repeatability(session, targets[0], repeats)
    session.use_analytic(True)
    analytic = throw_at(session, targets)
    session.world.close()
    mj = settings.mujoco
    return {
        "world": "mujoco",
        "path": "user: robot calibration (kept and reused as the commands do), train 25 rig-labelled throws, "
        "a fresh throw session per target",
        "targets": len(targets),
        "target_list_base_m": targets.tolist(),
        "errors_m": errors_m.tolist(),
        "failed_throws": int(np.isnan(errors_m).sum()),
        **_summary(errors_m),
        "demo_target_error_m": float(errors_m[0]),
        "calibration_ratio": calibration_error.ratio,
        "calibration_area_error": calibration_error.to_dict(),
        "calibration_kinematics": kinematics.get("kinematics") if isinstance(kinematics, dict) else None,
        "calibration_loo_m": calibration.loo_error_m,
        "trained_area": area.describe(),
        "repeatability_m": rep_rms,
        "repeatability_max_m": rep_max,
        "repeat_throws": repeats,
        "analytic_failed_throws": int(np.isnan(analytic).sum()),
        **_summary(analytic, "analytic_"),
        "release_tracking_error_mm": 1e3 * float(np.nanmedian(tracking)),
        "real_time_factor": rtf,
        "world_settings": {
            "release_latency_ms": 1e3 * mj.release_latency_s,
            "release_jitter_ms": 1e3 * mj.release_jitter_s,
            "placement_sigma_mm": 1e3 * mj.placement_sigma_m,
            "link_length_sigma_mm": 1e3 * mj.link_length_sigma_m,
            "joint_offset_sigma_mrad": 1e3 * mj.joint_offset_sigma_rad,
        },
        "goals": GOALS,
        "paper_accuracy_m": [0.02, 0.10],
        "paper_repeatability_m": [0.02, 0.03],
    }


def _kinematic(targets: NDArray[np.float64], repeats: int, n: int) -> dict[str, Any]:
    session = simulated_session(seed=0, quiet=True, learn=False)
    errors = throw_at(session, targets)
    rep_rms, rep_max, rtf = _repeatability(session, targets[0], repeats)

    exact = Settings().replace(noise=NoiseSettings(pixel_sigma_px=0.0, release_jitter_s=0.0, joint_tracking_rad=0.0))
    quiet_session = simulated_session(seed=0, settings=exact, quiet=True, learn=False)
    clean = throw_at(quiet_session, targets[: max(4, n // 4)])

    xz = np.column_stack([np.hypot(targets[:, 0], targets[:, 1]), targets[:, 2]])
    plan_ms = _plan_times(session, xz, approach=False)
    approach_ms = _plan_times(session, xz, approach=True)
    return {
        "world": "kinematic",
        "targets": n,
        "failed_throws": int(np.isnan(errors).sum()),
        **_summary(errors),
        "repeatability_m": rep_rms,
        "repeatability_max_m": rep_max,
        "repeat_throws": repeats,
        "real_time_factor": rtf,
        "generalization_error_m": float(np.nanmedian(clean)),
        "plan_p50_ms": float(np.percentile(plan_ms, 50)),
        "plan_p99_ms": float(np.percentile(plan_ms, 99)),
        "plan_with_approach_p50_ms": float(np.percentile(approach_ms, 50)),
        "plan_with_approach_p99_ms": float(np.percentile(approach_ms, 99)),
        "paper_accuracy_m": [0.02, 0.10],
        "paper_repeatability_m": [0.02, 0.03],
    }
