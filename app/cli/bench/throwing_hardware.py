"""`wiithrow bench throwing --settings S.json`: the throwing figures on the hardware path, every
landing measured by the rig.

What `calibrate --robot --settings`, `train --settings` and `throw --settings` do, in one process:
the drivers the settings name (`wiithrow.app.worlds.hardware.HardwareWorld`, on the system clock,
as `serve` runs them), the robot calibration (`DEFAULT_POSES` poses; `quick`: 20), the training's
throws labelled by the rig's measurement of the marker the operator puts where each ball first
touched down (25; `quick`: 10), then one throw per target, each scored by the rig (its measured
landing against its measured target), with the learning and then without it
(`throwing.AnalyticPlanner`, the nominal model's exact solution). Only the rig measures: the
operator here is the drivers' simulated operator (the MuJoCo drivers of
`examples/mujoco_settings.json` put the marker down at the touchdown), given `OPERATOR_WALK_S` to
walk over before the measurement, as the tests' operator presses Enter. A hand with the scheduled
release (`robot.gripper.ScheduledOpen`, the MuJoCo hand) opens at the release time on its own
clock; one without it is opened by the host, never more than `release_timing.RELEASE_LATE_BOUND_S`
late: a loaded host later than that keeps the ball and the throw fails. The targets are the user
path's (`throwing.user_path_targets`: the demo's first, then a grid over the trained area); each is
put down by the lab before its throw: a fresh world whose settings place it (`mujoco.target_base`:
the MuJoCo drivers' lab, one per clock).

Figures (JSON keys): `median_error_m`, `p95_error_m`, `max_error_m`, `errors_m` (rig-measured),
`share_within_50mm` (a cup's radius), `analytic_*` the same without the learning,
`learned_beats_analytic`; `true_*` where the hand's world knows the truth (the MuJoCo lab's
touchdown against the target it placed; never used to label or score); `calibration_loo_m`,
`training_regression_loo_median_m`. Goals (`GOALS`): median <= 15 mm, p95 <= 30 mm,
share within 50 mm >= 95 %, learned < analytic.

The figures measured, and the command: docs/performance.md, "Throwing".
"""

from __future__ import annotations

import dataclasses
from typing import Any

import numpy as np
from numpy.typing import NDArray

from wiithrow.app.calibration.robot import DEFAULT_POSES, RobotCalibrationOptions, calibrate_in_world
from wiithrow.app.cli.bench.throwing import user_path_targets
from wiithrow.app.cli.world_choice import LANDING_LOOKS
from wiithrow.app.errors import AppError, LandingNotMeasured
from wiithrow.app.rig.waiting import pump
from wiithrow.app.session import DEFAULT_MARGIN_M, Session
from wiithrow.app.settings import Settings
from wiithrow.app.throws.execution import measure_marker
from wiithrow.app.throws.training import train_in_world, training_grid
from wiithrow.app.worlds.hardware import HardwareWorld
from wiithrow.app.worlds.mujoco.drivers import lab_for
from wiithrow.clock import SimClock, SystemClock
from wiithrow.throwing import ThrowLibrary, TrainedArea, regression_leave_one_out_error, training_area
from wiithrow.vision import StereoCalibration

#: Goals on the hardware path: the rig-measured errors, the cup, the learning's worth.
GOALS = {"median_m": 0.015, "p95_m": 0.03, "share_within_50mm": 0.95, "learned_below_analytic": True}
#: How long (s) the operator takes to walk over and put the marker down after a throw came to rest.
OPERATOR_WALK_S = 2.0
#: The MuJoCo drivers (`gripper_driver` "module:factory"), whose lab a simulated-clock run builds
#: first with its own seed, and the first of those seeds.
MUJOCO_DRIVERS = "wiithrow.app.worlds.mujoco.drivers:"
SIM_CLOCK_SEED = 1000
#: The cup: a throw within this of its target (m) counts as in.
CUP_M = 0.05


def _world(
    settings: Settings, calibration: StereoCalibration | None = None, *, sim_clock: bool = False, draw: int = 0
) -> HardwareWorld:
    """A fresh world of the settings' drivers on its own clock (the MuJoCo drivers: its own lab).
    `sim_clock`: a simulated clock, and the MuJoCo drivers' lab built first with the seed `draw`,
    so that each world's hand draws its own jitter (its arm's tolerances are the settings' seed's)."""
    if not sim_clock:
        return HardwareWorld(settings, calibration=calibration, clock=SystemClock())
    clock = SimClock()
    if settings.gripper_driver.startswith(MUJOCO_DRIVERS):
        lab_for(clock, settings, seed=SIM_CLOCK_SEED + draw)
    return HardwareWorld(settings, calibration=calibration, clock=clock)  # type: ignore[arg-type]


def _operator_measures(world: HardwareWorld, what: str) -> NDArray[np.float64]:
    """What `train --settings` asks at its prompt, the operator answering after walking over
    (`OPERATOR_WALK_S`, the rig read meanwhile); looked for again when the rig sees no marker, up to
    `world_choice.LANDING_LOOKS` looks (then `LandingNotMeasured`)."""
    for _ in range(LANDING_LOOKS):
        pump(world.clock, world.rig, OPERATOR_WALK_S, step_s=0.01)
        point = measure_marker(world)
        if np.isfinite(point).all():
            return point
    raise LandingNotMeasured(f"{what}: the rig saw no landing marker in {LANDING_LOOKS} looks")


def _throw_once(
    settings: Settings,
    calibration: StereoCalibration,
    library: ThrowLibrary,
    analytic: bool,
    failures: list[str],
    *,
    sim_clock: bool = False,
    draw: int = 0,
) -> tuple[float, float, float]:
    """One `throw --settings --yes` at the target the settings' lab put down: (rig-measured error,
    true error or NaN, true error along the throw or NaN); NaNs for a throw that failed (joint 1 not aligned, a driver's refusal,
    no marker seen), its reason appended to `failures`: a failed throw is a miss, not the end of
    the benchmark."""
    world = _world(settings, sim_clock=sim_clock, draw=draw)
    # learn=False: the figures are the trained library's; `bench learning` measures the online learning
    session = Session(world, library=library, rng=np.random.default_rng(0), learn=False)
    try:
        session.use_calibration(calibration)
        session.use_analytic(analytic)
        session.margin_m = DEFAULT_MARGIN_M
        session.start()
        alignment = session.align()
        if not alignment.converged:
            failures.append(f"not aligned: {alignment.message}")
            return float("nan"), float("nan"), float("nan")
        preview = session.plan_preview(margin_m=DEFAULT_MARGIN_M)
        session.throw(preview.id)
        world.clock.sleep(OPERATOR_WALK_S)  # the operator walks over; the session's loop reads the rig
        record = session.measure_landing()
        return record.error_m, _true_error(world, settings), _along_error(world, settings)
    except Exception as exc:  # any failure of a throw is counted and said, not raised
        failures.append(f"{type(exc).__name__}: {exc}")
        return float("nan"), float("nan"), float("nan")
    finally:
        session.close()


def _along_error(world: HardwareWorld, settings: Settings) -> float:
    """Where the hand's world knows it: the touchdown's error along the throw direction (m, + long)."""
    lab = getattr(world.gripper, "lab", None)
    touchdown = getattr(getattr(lab, "events", None), "touchdown", None)
    if touchdown is None:
        return float("nan")
    target = np.asarray(settings.mujoco.target_base, dtype=float)[:2]
    return float((np.asarray(touchdown)[:2] - target) @ (target / np.linalg.norm(target)))


def _true_error(world: HardwareWorld, settings: Settings) -> float:
    """Where the hand's world knows it (the MuJoCo lab): the touchdown against the target it placed."""
    lab = getattr(world.gripper, "lab", None)
    touchdown = getattr(getattr(lab, "events", None), "touchdown", None)
    if touchdown is None:
        return float("nan")
    return float(np.linalg.norm(np.asarray(touchdown)[:2] - np.asarray(settings.mujoco.target_base)[:2]))


def _by_azimuth(targets: NDArray[np.float64], along: NDArray[np.float64]) -> dict[str, float | None]:
    """The median of the true error along the throw (m) at each azimuth of the targets (deg, rounded)."""
    azimuths = np.round(np.degrees(np.arctan2(targets[:, 1], targets[:, 0])))
    out: dict[str, float | None] = {}
    for a in sorted(set(azimuths.tolist())):
        chosen = along[azimuths == a]
        out[f"{a:+.0f}"] = float(np.nanmedian(chosen)) if np.isfinite(chosen).any() else None
    return out


def _summary(errors: NDArray[np.float64], prefix: str = "") -> dict[str, float]:
    return {
        f"{prefix}median_error_m": float(np.nanmedian(errors)),
        f"{prefix}p95_error_m": float(np.nanpercentile(errors, 95)),
        f"{prefix}max_error_m": float(np.nanmax(errors)),
        f"{prefix}share_within_50mm": float(np.mean(errors < CUP_M)),  # a failed throw (NaN) is out
    }


def run(settings_path: str, *, quick: bool = False, sim_clock: bool = False) -> dict[str, Any]:
    """The figures of the module docstring for the drivers `settings_path` names (`sim_clock`: on
    simulated clocks, each world's hand drawing its own jitter)."""
    settings = Settings.load(settings_path)
    if not (settings.arm_driver and settings.gripper_driver):
        raise AppError(
            f"bench throwing --settings throws: {settings_path} must name an arm_driver and a gripper_driver"
        )
    poses = 20 if quick else DEFAULT_POSES
    throws = 10 if quick else 25

    world = _world(settings, sim_clock=sim_clock)
    try:
        world.light("marker")
        world.connect()
        robot = calibrate_in_world(
            world, RobotCalibrationOptions(n_poses=poses, show_progress=False), rng=np.random.default_rng(0)
        )
        world.light("marker", False)
        calibration = robot.calibration
        world.set_calibration(calibration)
        library = train_in_world(
            world,
            np.random.default_rng(0),
            targets=training_grid(training_area(world.arm_model), throws),
            measure_landing=lambda target: _operator_measures(world, f"training throw at {np.round(target, 3)}"),
            meta={"bench": "throwing --settings", "settings": str(settings_path)},
        )
    finally:
        world.close()
    targets = user_path_targets(TrainedArea(library.landings), quick=quick)
    learned, learned_true, learned_along, analytic, analytic_true = [], [], [], [], []
    failures: list[str] = []
    analytic_failures: list[str] = []
    for k, target in enumerate(targets):
        where = (float(target[0]), float(target[1]), float(target[2]))
        placed = settings.replace(mujoco=dataclasses.replace(settings.mujoco, target_base=where))
        error, true, along = _throw_once(
            placed, calibration, library, False, failures, sim_clock=sim_clock, draw=2 * k + 1
        )
        learned.append(error)
        learned_true.append(true)
        learned_along.append(along)
        error, true, _ = _throw_once(
            placed, calibration, library, True, analytic_failures, sim_clock=sim_clock, draw=2 * k + 2
        )
        analytic.append(error)
        analytic_true.append(true)
    learned_m, analytic_m = np.array(learned), np.array(analytic)
    figures = _summary(learned_m)
    analytic_figures = _summary(analytic_m, "analytic_")
    regression = regression_leave_one_out_error(library)
    return {
        "world": "hardware",
        "settings": str(settings_path),
        "path": "hardware: robot calibration, training and throws through the settings' drivers on the "
        f"{'simulated' if sim_clock else 'system'} clock; every landing and target measured by the rig",
        "poses": poses,
        "training_throws": len(library.throws),
        "targets": len(targets),
        "target_list_base_m": targets.tolist(),
        "errors_m": learned_m.tolist(),
        "failed_throws": int(np.isnan(learned_m).sum()),
        "failures": failures,
        "analytic_failures": analytic_failures,
        **figures,
        "analytic_errors_m": analytic_m.tolist(),
        **analytic_figures,
        "learned_beats_analytic": bool(figures["median_error_m"] < analytic_figures["analytic_median_error_m"]),
        "true_median_error_m": float(np.nanmedian(learned_true)) if np.isfinite(learned_true).any() else None,
        "true_p95_error_m": float(np.nanpercentile(learned_true, 95)) if np.isfinite(learned_true).any() else None,
        "true_along_median_by_azimuth_m": _by_azimuth(targets, np.array(learned_along)),
        "true_analytic_median_error_m": float(np.nanmedian(analytic_true))
        if np.isfinite(analytic_true).any()
        else None,
        "calibration_loo_m": calibration.loo_error_m,
        "training_regression_loo_median_m": regression.median,
        "goals": GOALS,
    }
