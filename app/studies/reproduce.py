"""`wiithrow reproduce`: the paper's results on the simulated system, end to end, as files.

Owns the run, in this order (each step's data feed the next; all seeded):

1. the rig's coverage of the throwing area (`pose_selection.rig_coverage`);
2. the robot-driven calibration through the simulated remotes: N poses chosen by the optimal
   design, measured once (N = 60, `--quick` 30), calibrated with the refined DLT;
3. Fig. 5 (actual vs calculated positions of that set) and Fig. 4 (leave-one-out error against the
   number of points, by subsampling the N poses, every method);
4. the 30-pose calibration against the true cameras, for the optimal and a random pose spread:
   robot runs in fresh worlds (full run) and ideal-position studies over more seeds
   (`pose_selection.evaluate_design`);
5. Fig. 6: mono method against stereo while the hand turns the beacon pair;
6. joint-1 alignment to a target that starts outside the field of view (the tracking part);
7. `summary.md`: our numbers beside the paper's claims (`wiithrow.app.studies.figures.summary`).

Outputs in `out_dir`: calibration.json, calibration_poses.csv, fig4/5/6 PNG and CSV,
design_comparison.csv, summary.md.
"""

from __future__ import annotations

import os
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from tqdm import tqdm

from wiithrow.app.alignment.aligner import AlignmentResult, align_joint1
from wiithrow.app.calibration.points import calibrate_rig
from wiithrow.app.calibration.pose_selection import (
    DesignScore,
    RigCoverage,
    evaluate_design,
    rig_coverage,
    sample_candidates,
    score_calibration,
    select_poses,
)
from wiithrow.app.calibration.robot import PoseData, PoseMeasurer, calibrate_with_robot
from wiithrow.app.settings import Settings
from wiithrow.app.studies.figures import write_csv
from wiithrow.app.studies.figures.accuracy import FULL_SIZES, QUICK_SIZES, LooCurve, loo_curve, write_fig4
from wiithrow.app.studies.figures.mono import MonoVsStereo, mono_vs_stereo, write_fig6
from wiithrow.app.studies.figures.positions import ActualVsCalculated, actual_vs_calculated, write_fig5
from wiithrow.app.worlds import SimWorld, nominal_cameras
from wiithrow.vision import StereoCalibration


@dataclass(frozen=True)
class RunConfig:
    """How much to do: the full run or `--quick` (under a minute)."""

    quick: bool
    poses: int  # measured once, for Figs. 4 and 5
    sizes: tuple[int, ...]
    draws: int
    robot_seeds: int  # 30-pose robot calibrations per design (0: use the main data for "optimal")
    design_seeds: int  # ideal-position design comparisons per design
    angles_deg: tuple[float, ...]

    @classmethod
    def make(cls, quick: bool) -> RunConfig:
        if quick:
            return cls(True, 30, QUICK_SIZES, 1, 0, 3, (0.0, 15.0, 30.0, 45.0, 60.0, 75.0))
        return cls(False, 60, FULL_SIZES, 5, 3, 8, tuple(np.arange(0.0, 76.0, 5.0)))


@dataclass
class Reproduction:
    """Everything the run measured (see the module docstring), and the files it wrote."""

    config: RunConfig
    seed: int
    settings: Settings
    coverage: RigCoverage
    data: PoseData
    calibration: StereoCalibration
    loo_all_m: float
    fig4: LooCurve
    fig5: ActualVsCalculated
    fig6: MonoVsStereo
    robot30: dict[str, list[tuple[float, DesignScore]]]  # design -> [(LOO m, score vs truth)]
    designs: dict[str, list[DesignScore]]
    predicted: dict[str, float]
    alignment: AlignmentResult
    alignment_start_rad: float
    timings_s: dict[str, float] = field(default_factory=dict)
    files: list[Path] = field(default_factory=list)


def _robot_world(settings: Settings, seed: int) -> tuple[SimWorld, list]:
    world = SimWorld(settings, seed=seed)
    world.light("marker")
    world.connect()
    return world, nominal_cameras(settings.rig)


def run_reproduction(
    out_dir: str | os.PathLike[str],
    *,
    quick: bool = False,
    seed: int = 0,
    show_progress: bool = True,
    settings: Settings | None = None,
) -> Reproduction:
    """Run the whole reproduction (module docstring) and write its files to `out_dir`."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    cfg = RunConfig.make(quick)
    settings = settings or Settings()
    rng = np.random.default_rng(seed)
    timings: dict[str, float] = {}
    files: list[Path] = []
    clock = time.perf_counter

    steps = tqdm(total=6, desc="reproduce", unit="step", disable=not show_progress)
    # 1-2. coverage, candidates, the robot-driven calibration set
    t = clock()
    world, cameras = _robot_world(settings, seed)
    coverage = rig_coverage(cameras)
    candidates = sample_candidates(world.arm_model, cameras, np.random.default_rng(seed + 1))
    measurer = PoseMeasurer(
        world.arm, world.arm_model, world.rig, world.clock, cameras, rng=np.random.default_rng(seed + 2)
    )
    plan = select_poses(
        world.arm_model,
        cameras,
        cfg.poses,
        rng,
        candidates=candidates,
        start=measurer.marker_link1(world.arm.state().q),
    )
    data = measurer.run(plan, progress=None, show_progress=show_progress)
    fit = calibrate_rig(
        data.world,
        data.image,
        method="refined",
        frame="link1",
        meta={
            "source": "robot",
            "arm": settings.arm,
            "poses": len(data),
            "method": "refined",
            "design": plan.design,
            "simulated": True,
            "seed": seed,
        },
    )
    files.append(fit.calibration.save(out / "calibration.json"))
    files.append(_write_poses(out / "calibration_poses.csv", data))
    timings["robot calibration"] = clock() - t
    steps.update(1)

    # 3. Figs. 5 and 4
    t = clock()
    fig5 = actual_vs_calculated(fit.calibration, data.world, data.image)
    files += write_fig5(fig5, out)
    fig4 = loo_curve(
        data.world,
        data.image,
        np.random.default_rng(seed + 3),
        sizes=cfg.sizes,
        draws=cfg.draws,
        show_progress=show_progress,
    )
    files += write_fig4(fig4, out)
    timings["figs 4 and 5"] = clock() - t
    steps.update(1)

    # 4. 30 poses against the true cameras: robot runs, and the ideal-position design study
    t = clock()
    test = candidates.positions
    robot30: dict[str, list[tuple[float, DesignScore]]] = {"optimal": [], "random": []}
    if cfg.robot_seeds == 0:
        score = score_calibration(fit.calibration.Ps, world.cameras, test, np.random.default_rng(seed + 4))
        robot30["optimal"].append((fit.loo.mean, score))
    for design in ("optimal", "random") if cfg.robot_seeds else ():
        for k in range(cfg.robot_seeds):
            s = seed + 100 + k
            w, cams = _robot_world(settings, s)
            r = calibrate_with_robot(
                w.arm,
                w.arm_model,
                w.rig,
                w.clock,
                cams,
                n_poses=30,
                design=design,
                rng=np.random.default_rng(s),
                show_progress=False,
            )
            robot30[design].append(
                (r.loo.mean, score_calibration(r.calibration.Ps, w.cameras, test, np.random.default_rng(s)))
            )
            w.close()
    designs: dict[str, list[DesignScore]] = {"optimal": [], "random": []}
    predicted: dict[str, float] = {}
    for design in ("optimal", "random"):
        ratios = []
        for k in range(cfg.design_seeds):
            r = np.random.default_rng(seed + 200 + k)
            p = select_poses(world.arm_model, cameras, 30, r, design=design, candidates=candidates)
            designs[design].append(evaluate_design(cameras, p.positions, test, r, cross_validate=True))
            ratios.append(p.predicted_ratio)
        predicted[design] = float(np.mean(ratios))
    files.append(_write_designs(out / "design_comparison.csv", robot30, designs))
    timings["30-pose designs"] = clock() - t
    steps.update(1)

    # 5. Fig. 6 on the calibrated rig
    t = clock()
    world.set_calibration(fit.calibration)
    fig6 = mono_vs_stereo(world, fit.calibration, angles_deg=np.array(cfg.angles_deg), show_progress=show_progress)
    files += write_fig6(fig6, out)
    timings["fig 6"] = clock() - t
    steps.update(1)

    # 6. joint-1 alignment: a target on the floor 2 m away, 1.2 rad to the side of the cameras
    t = clock()
    world.rig.set_calibration(fit.calibration.Ps)
    start = float(world.arm.state().q[0])
    world.light("target", True, [2.0 * np.cos(start + 1.2), 2.0 * np.sin(start + 1.2), 0.0])
    alignment = align_joint1(world.arm, world.arm_model, world.rig, world.clock)
    world.light("target", False)
    world.close()
    timings["alignment"] = clock() - t
    steps.update(1)

    result = Reproduction(
        cfg,
        seed,
        settings,
        coverage,
        data,
        fit.calibration,
        fit.loo.mean,
        fig4,
        fig5,
        fig6,
        robot30,
        designs,
        predicted,
        alignment,
        start,
        timings,
        files,
    )
    from wiithrow.app.studies.figures.summary import summary_markdown
    from wiithrow.vision.files import atomic_write_text

    files.append(atomic_write_text(out / "summary.md", summary_markdown(result)))
    steps.update(1)
    steps.close()
    return result


def _write_poses(path: Path, data: PoseData) -> Path:
    C = data.image.shape[0]
    header = ["x_m", "y_m", "z_m"] + [f"{a}{c}_px" for c in range(C) for a in ("u", "v")]
    header += [f"q{j + 1}_rad" for j in range(data.q.shape[1])]
    rows = [
        (*map(float, data.world[i]), *map(float, data.image[:, i].ravel()), *map(float, data.q[i]))
        for i in range(len(data))
    ]
    return write_csv(path, header, rows)


def _write_designs(path: Path, robot30: dict, designs: dict) -> Path:
    rows = []
    for design, runs in robot30.items():
        for k, (loo, s) in enumerate(runs):
            rows.append(("robot", design, k, loo, s.test_m, s.true_test_m, s.ratio, s.calibration_m))
    for design, scores in designs.items():
        for k, s in enumerate(scores):
            rows.append(("ideal", design, k, s.loo_m, s.test_m, s.true_test_m, s.ratio, s.calibration_m))
    return write_csv(
        path,
        ["study", "design", "seed", "loo_m", "test_error_m", "true_cameras_error_m", "ratio", "calibration_share_m"],
        rows,
    )
