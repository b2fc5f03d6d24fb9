"""`wiithrow reproduce`: the paper's results on the simulated system, end to end, as files.

Owns the run, in this order (each step's data feed the next; all seeded):

1. the rig's coverage of the throwing area (`wiithrow.app.calibration.poses.rig_coverage`);
2. the robot-driven calibration through the simulated remotes: N poses chosen by the optimal
   design, measured once (N = 60, `--quick` 30), calibrated with the refined DLT;
3. Fig. 5 (actual vs calculated positions of that set) and Fig. 4 (leave-one-out error against the
   number of points, by subsampling the N poses, every method);
4. the 30-pose calibration against the true cameras, for the optimal and a random pose spread:
   robot runs in fresh worlds (full run) and ideal-position studies over more seeds
   (`wiithrow.app.calibration.poses.evaluate_design`);
5. Fig. 6: mono method against stereo while the hand turns the beacon pair;
6. joint-1 alignment to a target that starts outside the field of view (the tracking part);
7. `summary.md`: our numbers beside the paper's claims (`wiithrow.app.studies.figures.summary`).

Outputs in `out_dir` (`OUTPUT_NAMES`): calibration.json, calibration_poses.csv, fig4/5/6 PNG and
CSV, design_comparison.csv, summary.md. They are written all or none: into a hidden staging folder
beside `out_dir`, swapped in when the run is complete (`wiithrow.vision.outputs.replace_folder`),
so an interrupted or failed run leaves an existing `out_dir` exactly as it was. `out_dir` is
checked before the work: it must be a folder that can be made or replaced, and hold nothing but
an earlier run's outputs (a folder with other files is refused: swapping would lose them).
"""

from __future__ import annotations

import os
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from wiithrow.app.alignment import AlignmentResult, align_joint1
from wiithrow.app.calibration.points import calibrate_rig
from wiithrow.app.calibration.poses import (
    DESIGNS,
    DesignScore,
    RigCoverage,
    evaluate_design,
    rig_coverage,
    sample_candidates,
    score_calibration,
    select_poses,
)
from wiithrow.app.calibration.robot import PoseData, PoseMeasurer, calibrate_with_robot
from wiithrow.app.progress import progress_bar
from wiithrow.app.settings import Settings
from wiithrow.app.studies.figures import write_csv
from wiithrow.app.studies.figures.accuracy import FULL_SIZES, QUICK_SIZES, LooCurve, loo_curve, write_fig4
from wiithrow.app.studies.figures.mono import MonoVsStereo, mono_vs_stereo, write_fig6
from wiithrow.app.studies.figures.positions import ActualVsCalculated, actual_vs_calculated, write_fig5
from wiithrow.app.worlds import RigWorld, SimWorld, nominal_cameras
from wiithrow.app.worlds.named import make_world
from wiithrow.vision import StereoCalibration
from wiithrow.vision.errors import OutputPathError
from wiithrow.vision.files import atomic_write_text
from wiithrow.vision.outputs import check_output_folder, new_staging_folder, remove_staging_folder, replace_folder

#: What a run writes into its folder.
OUTPUT_NAMES = (
    "calibration.json",
    "calibration_poses.csv",
    "fig4_loo_vs_points.csv",
    "fig4_loo_vs_points.png",
    "fig5_actual_vs_calculated.csv",
    "fig5_actual_vs_calculated.png",
    "fig6_mono_vs_stereo.csv",
    "fig6_mono_vs_stereo.png",
    "design_comparison.csv",
    "summary.md",
)


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
    world: str = "kinematic"  # the simulated world of the calibration and alignment studies


def _robot_world(settings: Settings, seed: int, world_name: str = "kinematic") -> tuple[RigWorld, list]:
    world = make_world(world_name, settings, seed=seed)
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
    world: str = "kinematic",
) -> Reproduction:
    """Run the whole reproduction (module docstring) and write its files to `out_dir`, all or none.
    `world`: the simulated world of the calibration and alignment studies (`WORLDS`); Fig. 6
    always runs in the kinematic world, whose hand carries the beacon pair."""
    out = check_reproduction_folder(out_dir)
    staging = new_staging_folder(out)
    try:
        result = _run_into(staging, quick, seed, show_progress, settings, world)
        replace_folder(staging, out)
    except BaseException:
        remove_staging_folder(staging)
        raise
    result.files = [out / path.name for path in result.files]
    return result


def check_reproduction_folder(out_dir: str | os.PathLike[str]) -> Path:
    """`out_dir`, checked before the work (module docstring); OutputPathError saying what is wrong."""
    out = check_output_folder(out_dir)
    if out.is_dir():
        foreign = sorted(p.name for p in out.iterdir() if p.name not in OUTPUT_NAMES)
        if foreign:
            shown = ", ".join(foreign[:3]) + (", ..." if len(foreign) > 3 else "")
            raise OutputPathError(
                f"{out} holds files a reproduction does not write ({shown}); a run replaces the whole folder: "
                "choose another one, or move them out"
            )
    return out


def _run_into(
    out: Path, quick: bool, seed: int, show_progress: bool, settings: Settings | None, world: str = "kinematic"
) -> Reproduction:
    run = _Run(RunConfig.make(quick), seed, settings or Settings(), out, show_progress, world)
    steps = [
        ("robot calibration", run.calibrate),
        ("figs 4 and 5", run.figures_4_and_5),
        ("30-pose designs", run.designs),
        ("fig 6", run.figure_6),
        ("alignment", run.alignment),
    ]
    with progress_bar(total=len(steps) + 1, show=show_progress, desc="reproduce", unit="step") as bar:
        for name, step in steps:
            start = time.perf_counter()
            step()
            run.timings[name] = time.perf_counter() - start
            bar.update(1)
        result = run.result()
        from wiithrow.app.studies.figures.summary import summary_markdown

        result.files.append(atomic_write_text(out / "summary.md", summary_markdown(result)))
        bar.update(1)
    return result


class _Run:
    """The steps of one reproduction, in order, each keeping what the next ones need."""

    def __init__(
        self, cfg: RunConfig, seed: int, settings: Settings, out: Path, show_progress: bool, world: str = "kinematic"
    ) -> None:
        self.cfg, self.seed, self.settings, self.out, self.show_progress = cfg, seed, settings, out, show_progress
        self.world_name = world
        self.rng = np.random.default_rng(seed)
        self.timings: dict[str, float] = {}
        self.files: list[Path] = []

    def calibrate(self) -> None:
        """1-2: coverage, candidate poses, the robot-driven calibration set, measured once."""
        seed = self.seed
        self.world, cameras = _robot_world(self.settings, seed, self.world_name)
        self.cameras = cameras
        self.coverage = rig_coverage(cameras)
        self.candidates = sample_candidates(self.world.arm_model, cameras, np.random.default_rng(seed + 1))
        w = self.world
        measurer = PoseMeasurer(w.arm, w.arm_model, w.rig, w.clock, cameras, rng=np.random.default_rng(seed + 2))
        plan = select_poses(
            w.arm_model,
            cameras,
            self.cfg.poses,
            self.rng,
            candidates=self.candidates,
            start=measurer.marker_link1(w.arm.state().q),
        )
        self.data = measurer.run(plan, progress=None, show_progress=self.show_progress)
        meta = {
            "source": "robot",
            "arm": self.settings.arm,
            "poses": len(self.data),
            "method": "refined",
            "design": plan.design,
            "simulated": True,
            "seed": seed,
        }
        self.fit = calibrate_rig(self.data.positions, self.data.image, method="refined", frame="link1", meta=meta)
        self.files.append(self.fit.calibration.save(self.out / "calibration.json"))
        self.files.append(_write_poses(self.out / "calibration_poses.csv", self.data))

    def figures_4_and_5(self) -> None:
        """3: Fig. 5 (actual vs calculated) and Fig. 4 (leave-one-out error vs number of points)."""
        self.fig5 = actual_vs_calculated(self.fit.calibration, self.data.positions, self.data.image)
        self.files += write_fig5(self.fig5, self.out)
        self.fig4 = loo_curve(
            self.data.positions,
            self.data.image,
            np.random.default_rng(self.seed + 3),
            sizes=self.cfg.sizes,
            draws=self.cfg.draws,
            show_progress=self.show_progress,
        )
        self.files += write_fig4(self.fig4, self.out)

    def designs(self) -> None:
        """4: 30 poses against the true cameras: robot runs in fresh worlds, ideal-position studies."""
        seed, test = self.seed, self.candidates.positions
        self.robot30: dict[str, list[tuple[float, DesignScore]]] = {"optimal": [], "random": []}
        if self.cfg.robot_seeds == 0:
            score = score_calibration(
                self.fit.calibration.Ps, self.world.cameras, test, np.random.default_rng(seed + 4)
            )
            self.robot30["optimal"].append((self.fit.loo.mean, score))
        for design in DESIGNS if self.cfg.robot_seeds else ():
            for k in range(self.cfg.robot_seeds):
                s = seed + 100 + k
                w, cams = _robot_world(self.settings, s, self.world_name)
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
                score = score_calibration(r.calibration.Ps, w.cameras, test, np.random.default_rng(s))
                self.robot30[design].append((r.loo.mean, score))
                w.close()
        self.design_scores: dict[str, list[DesignScore]] = {"optimal": [], "random": []}
        self.predicted: dict[str, float] = {}
        for design in DESIGNS:
            ratios = []
            for k in range(self.cfg.design_seeds):
                draw = np.random.default_rng(seed + 200 + k)
                p = select_poses(
                    self.world.arm_model, self.cameras, 30, draw, design=design, candidates=self.candidates
                )
                self.design_scores[design].append(
                    evaluate_design(self.cameras, p.positions, test, draw, cross_validate=True)
                )
                ratios.append(p.predicted_ratio)
            self.predicted[design] = float(np.mean(ratios))
        self.files.append(_write_designs(self.out / "design_comparison.csv", self.robot30, self.design_scores))

    def figure_6(self) -> None:
        """5: Fig. 6, the mono method against stereo, on the calibrated rig (in the kinematic world,
        whose hand carries the beacon pair: a twin of the MuJoCo world's rig when that one is run)."""
        angles = np.array(self.cfg.angles_deg)
        world = self.world if isinstance(self.world, SimWorld) else SimWorld(self.settings, seed=self.seed)
        try:
            world.set_calibration(self.fit.calibration)
            self.fig6 = mono_vs_stereo(world, self.fit.calibration, angles_deg=angles, show_progress=self.show_progress)
        finally:
            if world is not self.world:
                world.close()
        self.files += write_fig6(self.fig6, self.out)

    def alignment(self) -> None:
        """6: joint-1 alignment to a target on the floor 2 m away, 1.2 rad to the side of the cameras."""
        w = self.world
        w.rig.set_calibration(self.fit.calibration.Ps)
        self.alignment_start = float(w.arm.state().q[0])
        a = self.alignment_start + 1.2
        w.light("marker", False)  # the target is the only lit IR source
        w.light("target", True, [2.0 * np.cos(a), 2.0 * np.sin(a), 0.0])
        self.aligned = align_joint1(w)
        w.light("target", False)
        w.close()

    def result(self) -> Reproduction:
        return Reproduction(
            self.cfg,
            self.seed,
            self.settings,
            self.coverage,
            self.data,
            self.fit.calibration,
            self.fit.loo.mean,
            self.fig4,
            self.fig5,
            self.fig6,
            self.robot30,
            self.design_scores,
            self.predicted,
            self.aligned,
            self.alignment_start,
            self.timings,
            self.files,
            self.world_name,
        )


def _write_poses(path: Path, data: PoseData) -> Path:
    C = data.image.shape[0]
    header = ["x_m", "y_m", "z_m"] + [f"{a}{c}_px" for c in range(C) for a in ("u", "v")]
    header += [f"q{j + 1}_rad" for j in range(data.q.shape[1])]
    rows = [
        (*map(float, data.positions[i]), *map(float, data.image[:, i].ravel()), *map(float, data.q[i]))
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
