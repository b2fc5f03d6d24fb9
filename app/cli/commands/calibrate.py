"""`wiithrow calibrate`: fit the rig's cameras from known 3D points, or run the simulated study.

wiithrow calibrate --points points.csv [--method refined] [--out calibration.json] [--dlt-csv dlt.csv]
wiithrow calibrate --demo [--seed 0]
wiithrow calibrate --robot [--sim] [--points N]      (robot-driven, the paper's procedure)
"""

from __future__ import annotations

import argparse
import json

import numpy as np

from wiithrow.app.calibration.point_files import read_calibration_points
from wiithrow.app.calibration.points import calibrate_rig
from wiithrow.app.errors import AppError
from wiithrow.app.studies.calibration_methods import run_demo
from wiithrow.app.tables import format_table
from wiithrow.vision import save_dlt_coefficients
from wiithrow.vision.dlt import METHODS

NAME = "calibrate"
HELP = "fit the cameras from known 3D points (a CSV, the robot, or the simulated --demo)"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    source = parser.add_mutually_exclusive_group()
    source.add_argument(
        "--demo", action="store_true", help="simulated Wiimote rig: compare every method with the true cameras"
    )
    source.add_argument(
        "--robot", action="store_true", help="drive the arm through marker poses (the paper's procedure)"
    )
    parser.add_argument(
        "--points",
        metavar="FILE.csv|N",
        help="a CSV of x, y, z, then u, v per camera (NaN where unseen); with --robot, the number of poses (default 30)",
    )
    parser.add_argument("--method", choices=METHODS, default="refined", help="calibration method (default: refined)")
    parser.add_argument(
        "--out", default="calibration.json", help="where to write the calibration (default: calibration.json)"
    )
    parser.add_argument(
        "--dlt-csv", metavar="FILE.csv", help="also write the 11 DLT coefficients per camera (DLTdv/easyWand)"
    )
    parser.add_argument(
        "--frame", default="link1", help="name of the frame the 3D points are given in (default: link1)"
    )
    parser.add_argument("--seed", type=int, default=0, help="random seed of simulations (default: 0)")
    parser.add_argument("--sim", action="store_true", help="with --robot: use the simulated arm and remotes")
    parser.add_argument(
        "--world",
        choices=("mujoco", "kinematic"),
        default="kinematic",
        help="with --robot --sim: the simulated world (default: kinematic)",
    )
    parser.add_argument("--json", action="store_true", help="print the result as JSON")


def run(args: argparse.Namespace) -> int:
    if args.demo:
        return _demo(args)
    if args.robot:
        from wiithrow.app.cli.commands.calibrate_robot import run_robot_calibration

        return run_robot_calibration(args)
    if not args.points:
        raise AppError("give the calibration points: --points FILE.csv (or use --demo or --robot)")
    return _from_file(args)


def _from_file(args: argparse.Namespace) -> int:
    world, image = read_calibration_points(args.points)
    result = calibrate_rig(world, image, method=args.method, frame=args.frame, meta={"source": str(args.points)})
    path = result.calibration.save(args.out)
    if args.dlt_csv:
        save_dlt_coefficients(args.dlt_csv, result.calibration.Ps)
    if args.json:
        print(
            json.dumps(
                {
                    "calibration": str(path),
                    "cameras": [
                        {"name": c.name, "points": int(c.world.shape[0]), "rms_px": c.rms_px}
                        for c in result.calibration.cameras
                    ],
                    "loo_error_m": result.loo.mean,
                    "worst_points": [
                        {"index": int(i), "error_m": float(result.loo.errors[i])} for i in result.loo.worst(5)
                    ],
                },
                indent=2,
            )
        )
        return 0
    rows = [(c.name, int(c.world.shape[0]), c.rms_px) for c in result.calibration.cameras]
    print(format_table(["camera", "points", "RMS px"], rows))
    print(
        f"\nleave-one-out 3D error: {1e3 * result.loo.mean:.2f} mm (mean over {np.isfinite(result.loo.errors).sum()} points)"
    )
    worst = ", ".join(f"#{i} {1e3 * result.loo.errors[i]:.1f} mm" for i in result.loo.worst(3))
    print(f"worst points: {worst}")
    print(f"wrote {path}" + (f" and {args.dlt_csv}" if args.dlt_csv else ""))
    return 0


def _demo(args: argparse.Namespace) -> int:
    result = run_demo(np.random.default_rng(args.seed))
    if args.json:
        print(
            json.dumps(
                {
                    "n_points": result.n_points,
                    "n_test": result.n_test,
                    "sigma_px": result.sigma_px,
                    "true_cameras_test_mm": result.true_test_mm,
                    "origin_depth_m": result.origin_depth_m,
                    "methods": [m.__dict__ for m in result.methods],
                },
                indent=2,
            )
        )
        return 0
    print(
        f"Simulated Wiimote stereo rig: 2 cameras 0.25 m apart, f = 1300 px, {result.n_points} calibration "
        f"points at 0.5-1.2 m,\nsigma = {result.sigma_px} px noise rounded to integer pixels; "
        f"{result.n_test} test points in the same volume.\n"
    )
    rows = [
        (m.method, m.rms_px, m.loo_mm, m.test_mm, m.ratio, m.focal_error_pct, m.center_error_mm) for m in result.methods
    ]
    print(format_table(["method", "RMS px", "LOO mm", "test mm", "x true", "focal err %", "centre err mm"], rows))
    print(f"\ntrue cameras on the same noisy pixels: {result.true_test_mm:.3f} mm (the irreducible error)")
    depth = ", ".join(f"{d:+.3f} m" for d in result.origin_depth_m)
    print(
        f"The frame's origin lies at depth {depth} in the cameras: the closer to 0, the worse the paper's\n"
        "a34 = 1 solve (p34 is the origin's depth, which it fixes to 1); the normalised methods do not care."
    )
    return 0
