"""`wiithrow calibrate --robot (--settings S.json | --sim [--world W]) [--points N]`: the robot-driven
calibration from the command line.

`wiithrow.app.cli.commands.calibrate` dispatches `--robot` here. With `--sim` it runs on a simulated world
(MuJoCo unless `--world kinematic`; the arm of the settings, simulated remotes), prints the
per-camera table, the leave-one-out 3D error, the worst poses (numbered from 1, in the order
measured), the skipped poses and, since the simulation knows the true cameras, the calibrated rig
against them; then writes the calibration (and the DLT CSV), all or none. With `--settings` it
runs the same procedure through the arm and remotes drivers the settings name
(`wiithrow.app.cli.world_choice.hardware_world`, as `wiithrow serve --settings`), where nothing
knows the true cameras. Neither is one line saying what to pass. The first line on stderr names
the world. The outputs are checked before the arm moves.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from wiithrow.app.calibration.kinematic import Kinematics
from wiithrow.app.calibration.points import RigCalibration
from wiithrow.app.calibration.poses import DesignScore, sample_candidates, score_calibration
from wiithrow.app.calibration.robot import DEFAULT_POSES, RobotCalibration, RobotCalibrationOptions, calibrate_in_world
from wiithrow.app.calibration.simulated import calibrate_simulated_rig
from wiithrow.app.calibration.truth import area_error
from wiithrow.app.cli.commands.calibrate import DEFAULT_METHOD, loo_json, loo_text, outputs, write_outputs
from wiithrow.app.cli.json_output import emit
from wiithrow.app.cli.world_choice import (
    hardware_world,
    require_world_choice,
    say_world,
    sim_world_line,
    sim_world_name,
)
from wiithrow.app.errors import AppError
from wiithrow.app.settings import Settings
from wiithrow.app.tables import format_table
from wiithrow.throwing import training_area
from wiithrow.vision.dlt import Method


def pose_count(points: str | None) -> int:
    """`--points` read as the number of poses (default `DEFAULT_POSES`); AppError unless an integer >= 6."""
    if points is None:
        return DEFAULT_POSES
    try:
        n = int(points)
    except ValueError:
        raise AppError(
            f"with --robot, --points is the number of poses (an integer, default {DEFAULT_POSES}), got {points!r}"
        ) from None
    if n < 6:
        raise AppError(f"a calibration needs at least 6 poses (the paper recommends 30 or more), got {n}")
    return n


def run_robot_calibration(args: argparse.Namespace) -> int:
    n = pose_count(getattr(args, "points", None))
    require_world_choice(args, "calibrate with the robot")
    out, dlt = outputs(args)
    if args.settings:
        return _on_hardware(args, n, out, dlt)
    seed = args.seed or 0
    method: Method = args.method or DEFAULT_METHOD
    kinematics: Kinematics = getattr(args, "kinematics", None) or "identified"
    settings = Settings()
    world_name = sim_world_name(args)
    say_world(sim_world_line(world_name))
    result, world = calibrate_simulated_rig(
        settings,
        seed=seed,
        n_poses=n,
        method=method,
        kinematics=kinematics,
        show_progress=not args.json,
        world_name=world_name,
    )
    try:
        candidates = sample_candidates(world.arm_model, world.cameras, np.random.default_rng(seed + 1))
        truth = score_calibration(
            result.calibration.Ps,
            world.cameras,
            candidates.positions,
            np.random.default_rng(seed + 2),
            sigma_px=settings.noise.pixel_sigma_px,
        )
        area = area_error(world, result.calibration, np.random.default_rng(seed + 3))
    finally:
        world.close()
    written = write_outputs(result.calibration, out, dlt)
    if args.json:
        report = report_dict(result, truth)
        report["against_true_cameras"]["throwing_area"] = area.to_dict()
        emit({**report, "world": world_name, "calibration": str(out), "dlt_csv": str(dlt) if dlt else None})
    else:
        print(format_report(result, truth))
        print(
            f"over the throwing area ({training_area(world.arm_model)}), beyond the calibrated volume: "
            f"{1e3 * area.calibrated_m:.2f} mm vs {1e3 * area.true_m:.2f} mm (x {area.ratio:.2f}; median 3D error on "
            "the same pixels)"
        )
        print("wrote " + " and ".join(str(p) for p in written))
    return 0


def _on_hardware(args: argparse.Namespace, n: int, out: Path, dlt: Path | None) -> int:
    """The paper's procedure through the drivers `--settings` names: the arm carries its LED
    (switched by the driver when it can, else lit by the operator) through `n` poses, the rig
    measures it at each; nothing here knows the true cameras."""
    world = hardware_world(args, "calibrate")
    method: Method = args.method or DEFAULT_METHOD
    kinematics: Kinematics = getattr(args, "kinematics", None) or "identified"
    try:
        world.light("marker")
        world.connect()
        options = RobotCalibrationOptions(
            n_poses=n,
            method=method,
            kinematics=kinematics,
            show_progress=not args.json,
            meta={"simulated": False, "settings": str(args.settings)},
        )
        result = calibrate_in_world(world, options, rng=np.random.default_rng(args.seed or 0))
        world.light("marker", False)
    finally:
        world.close()
    written = write_outputs(result.calibration, out, dlt)
    if args.json:
        emit(
            {**report_dict(result), "world": "hardware", "calibration": str(out), "dlt_csv": str(dlt) if dlt else None}
        )
    else:
        print(format_report(result))
        print("wrote " + " and ".join(str(p) for p in written))
    return 0


def report_dict(result: RobotCalibration, truth: DesignScore | None = None, path: Path | None = None) -> dict:
    """The run as JSON-ready data (poses numbered from 1, in the order measured)."""
    loo = loo_json(RigCalibration(result.calibration, result.loo), "pose")
    for entry in loo["worst_poses"]:
        entry["position_link1"] = result.data.positions[entry["pose"] - 1].tolist()
    out = {
        "calibration": str(path) if path else None,
        "arm": result.meta.get("arm"),
        "poses": len(result.data),
        "design": result.plan.design,
        "method": result.meta.get("method"),
        "kinematics": result.meta.get("kinematics"),
        "duration_s": result.data.duration_s,
        "cameras": [
            {"name": c.name, "points": int(c.world.shape[0]), "rms_px": c.rms_px} for c in result.calibration.cameras
        ],
        **loo,
        "skipped": [{"target_link1": s.target.tolist(), "reason": s.reason} for s in result.data.skipped],
        "predicted_ratio": result.plan.predicted_ratio,
    }
    if truth is not None:
        out["against_true_cameras"] = {
            "test_error_m": truth.test_m,
            "true_cameras_error_m": truth.true_test_m,
            "ratio": truth.ratio,
            "calibration_share_m": truth.calibration_m,
        }
    return out


def kinematics_text(kinematics: object) -> str:
    """One line on the arm's kinematics the calibration used (`wiithrow.app.calibration.kinematic`)."""
    if not isinstance(kinematics, dict):
        return "kinematics: nominal"
    held = kinematics.get("held_out_rms_px")
    cv = (
        f" (held-out poses: {held['identified']:.2f} px identified vs {held['nominal']:.2f} px nominal)"
        if isinstance(held, dict)
        else ""
    )
    if kinematics.get("kinematics") == "identified":
        count = len(kinematics.get("corrections", {}))
        return f"kinematics: {count} corrections of the arm's kinematics identified with the cameras{cv}"
    why = kinematics.get("why")
    return f"kinematics: nominal{f': {why}' if why else ''}{cv}"


def format_report(result: RobotCalibration, truth: DesignScore | None = None) -> str:
    """The printed table: per camera, leave-one-out error, worst poses, skipped poses, truth."""
    cams = result.calibration.cameras
    lines = [
        f"Robot-driven calibration: arm {result.meta.get('arm')}, {len(result.data)} poses ({result.plan.design} "
        f"spread), {result.meta.get('frames_per_pose')} frames averaged per pose, method {result.meta.get('method')}, "
        f"{result.data.duration_s:.1f} s on the arm's clock.",
        "",
        format_table(["camera", "points", "RMS px"], [(c.name, int(c.world.shape[0]), c.rms_px) for c in cams]),
        "",
        loo_text(RigCalibration(result.calibration, result.loo), "poses", 3, result.data.positions),
        kinematics_text(result.meta.get("kinematics")),
    ]
    if result.data.skipped:
        lines.append(f"skipped and replaced {len(result.data.skipped)} poses:")
        lines += [f"  {np.round(s.target, 3).tolist()}: {s.reason}" for s in result.data.skipped]
    else:
        lines.append("no pose was skipped")
    if truth is not None:
        lines.append(
            f"against the true simulated cameras, on one noisy frame of test points in the calibrated volume: "
            f"{1e3 * truth.test_m:.3f} mm vs {1e3 * truth.true_test_m:.3f} mm (x {truth.ratio:.3f}; "
            f"predicted x {result.plan.predicted_ratio:.3f})"
        )
    return "\n".join(lines)
