"""`wiithrow calibrate`: fit the rig's cameras from known 3D points, or run the simulated study.

wiithrow calibrate --points points.csv [--method refined] [--frame link1] [--out cal.json] [--dlt-csv dlt.csv] [--force]
wiithrow calibrate --demo [--seed 0]
wiithrow calibrate --robot (--settings S.json | --sim [--world mujoco|kinematic]) [--points N] [--method refined]
                    [--out cal.json] [--dlt-csv dlt.csv] [--force]
wiithrow calibrate --wand [--sim | --points wand.csv] [--wand-length L] ...   (a wand, no robot: calibrate_wand)

Each mode refuses the flags that do not apply to it. Before any work the outputs are checked
(`arguments.output_file`): the default `calibration.json`, which the user did not name, is not
replaced without `--force`; a calibration that is replaced is kept in `<name>.versions/` beside it
and its figures are printed beside the new one's (`wiithrow.app.calibration.versions`). The
calibration and the DLT CSV are written together, all or none (`wiithrow.vision.outputs.OutputFiles`),
after everything that can fail. Points are numbered
from 1: point k is the k-th data row of the file (or the k-th pose measured).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

from wiithrow.app.calibration.kinematic import KINEMATICS
from wiithrow.app.calibration.point_files import read_calibration_points
from wiithrow.app.calibration.points import RigCalibration, calibrate_rig
from wiithrow.app.calibration.versions import keep_and_compare
from wiithrow.app.cli.arguments import output_file, refuse_flags, seed
from wiithrow.app.cli.commands import calibrate_wand
from wiithrow.app.cli.json_output import emit
from wiithrow.app.errors import AppError
from wiithrow.app.studies.calibration_methods import run_demo
from wiithrow.app.tables import format_table
from wiithrow.app.worlds.named import WORLDS
from wiithrow.vision.dlt import METHODS, Method
from wiithrow.vision.errors import OutputPathError
from wiithrow.vision.outputs import OutputFiles
from wiithrow.vision.stereo_calibration import StereoCalibration, dlt_coefficients_text

NAME = "calibrate"
HELP = "fit the cameras from known 3D points (a CSV, the robot, a wand, or the simulated --demo)"

DEFAULT_OUT = "calibration.json"
DEFAULT_METHOD: Method = "refined"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    source = parser.add_mutually_exclusive_group()
    source.add_argument(
        "--demo", action="store_true", help="simulated Wiimote rig: compare every method with the true cameras"
    )
    source.add_argument(
        "--robot", action="store_true", help="drive the arm through marker poses (the paper's procedure)"
    )
    source.add_argument(
        "--wand",
        action="store_true",
        help="2-4 remotes from a wand (two LEDs a known distance apart) waved through the volume, no robot needed",
    )
    parser.add_argument(
        "--points",
        metavar="FILE.csv|N",
        help="a CSV of x, y, z, then u, v per camera (NaN where unseen); with --robot, the number of poses "
        "(default 60); with --wand, a wand CSV (t, then c<i>_a_u, c<i>_a_v, c<i>_b_u, c<i>_b_v per camera)",
    )
    parser.add_argument("--method", choices=METHODS, help=f"calibration method (default: {DEFAULT_METHOD})")
    parser.add_argument(
        "--kinematics",
        choices=KINEMATICS,
        help="with --robot: identify the arm's kinematic errors with the cameras (identified, the default) "
        "or take the nominal kinematics as exact (nominal, the paper's procedure)",
    )
    parser.add_argument(
        "--out",
        help=f"where to write the calibration (default: {DEFAULT_OUT}, which is not replaced without --force)",
    )
    parser.add_argument(
        "--dlt-csv", metavar="FILE.csv", help="also write the 11 DLT coefficients per camera (DLTdv/easyWand)"
    )
    parser.add_argument("--force", action="store_true", help=f"replace {DEFAULT_OUT} when --out is not given")
    parser.add_argument(
        "--frame",
        help="with --points FILE.csv: the name of the frame the 3D points are given in (default: link1); with --wand: "
        "camera (the first camera's, default), lframe (an L-frame's three LEDs) or robot (link1, from arm poses)",
    )
    parser.add_argument(
        "--seed", type=seed, help="random seed of the simulations (--demo, --robot, --wand; default: 0)"
    )
    parser.add_argument("--sim", action="store_true", help="with --robot or --wand: use the simulated arm and remotes")
    parser.add_argument(
        "--world",
        choices=WORLDS,
        help="with --sim (--robot, --wand): the simulated world, mujoco (physics the planner does not know, the "
        "demo's) or kinematic (the planner's own models, fast) (default: mujoco)",
    )
    parser.add_argument("--json", action="store_true", help="print the result as JSON")
    calibrate_wand.add_arguments(parser)


def run(args: argparse.Namespace) -> int:
    if not args.wand:
        # --settings is also --robot's: the arm and remotes drivers it names (the hardware path)
        wand_only = [o for o in calibrate_wand.WAND_OPTIONS if not (args.robot and o == "settings")]
        refuse_flags(args, wand_only, "without --wand")
    if args.demo:
        refuse_flags(args, ("points", "method", "out", "dlt_csv", "force", "frame", "sim", "world"), "to --demo")
        return _demo(args)
    if args.robot:
        refuse_flags(args, ("frame",), "to --robot (it calibrates in link1, the frame the rig turns with)")
        from wiithrow.app.cli.commands.calibrate_robot import run_robot_calibration

        return run_robot_calibration(args)
    if args.wand:
        return calibrate_wand.run_wand_calibration(args)
    refuse_flags(args, ("seed", "sim", "world"), "to --points FILE.csv (they are for --demo and --robot)")
    if not args.points:
        raise AppError("give the calibration points: --points FILE.csv (or use --demo or --robot)")
    return _from_file(args)


def outputs(args: argparse.Namespace) -> tuple[Path, Path | None]:
    """The calibration's and the DLT CSV's paths, checked before any work."""
    out = output_file(args, "out", DEFAULT_OUT)
    dlt = output_file(args, "dlt_csv")
    assert out is not None
    if dlt is not None and dlt.resolve() == out.resolve():
        raise OutputPathError(f"--out and --dlt-csv name the same file ({out}): give two files")
    return out, dlt


def write_outputs(calibration: StereoCalibration, out: Path, dlt: Path | None) -> list[Path]:
    """Write the calibration (and its DLT CSV) together: all or none; a calibration it replaces is
    kept, its figures printed beside the new one's (`wiithrow.app.calibration.versions`)."""
    keep_and_compare(out, calibration, say_replaced)
    files = OutputFiles().add(out, calibration.write_json)
    if dlt is not None:
        files.add(dlt, dlt_coefficients_text(calibration.Ps))
    return files.commit()


def say_replaced(line: str) -> None:
    """A line of the replaced calibration's comparison, on stderr (stdout is the command's result)."""
    print(f"wiithrow calibrate: {line}", file=sys.stderr)


def _from_file(args: argparse.Namespace) -> int:
    out, dlt = outputs(args)
    world, image = read_calibration_points(args.points)
    method: Method = args.method or DEFAULT_METHOD
    result = calibrate_rig(
        world,
        image,
        method=method,
        frame=args.frame or "link1",
        meta={"source": str(args.points)},
        show_progress=not args.json,
    )
    written = write_outputs(result.calibration, out, dlt)
    if args.json:
        emit(
            {
                "calibration": str(out),
                "dlt_csv": str(dlt) if dlt is not None else None,
                "frame": result.calibration.frame,
                "method": method,
                "cameras": [
                    {"name": c.name, "points": int(c.world.shape[0]), "rms_px": c.rms_px}
                    for c in result.calibration.cameras
                ],
                **loo_json(result, "point"),
            }
        )
        return 0
    rows = [(c.name, int(c.world.shape[0]), c.rms_px) for c in result.calibration.cameras]
    print(format_table(["camera", "points", "RMS px"], rows))
    print()
    print(loo_text(result, "points"))
    print("wrote " + " and ".join(str(p) for p in written))
    return 0


def loo_json(result: RigCalibration, unit: str) -> dict:
    """The leave-one-out part of a calibration's JSON: mean error (null when no point could be
    tested, with the reason), and the worst points numbered from 1 under key `unit`."""
    loo = result.loo
    return {
        "loo_error_m": loo.mean if loo.tested else None,
        "loo_tested": loo.tested,
        "loo_note": loo.reason or None,
        f"worst_{unit}s": [{unit: int(i) + 1, "error_m": float(loo.errors[i])} for i in loo.worst(5)],
    }


def loo_text(result: RigCalibration, what: str, digits: int = 2, positions: np.ndarray | None = None) -> str:
    """The leave-one-out lines of a calibration's report: the mean, and the worst three (from 1),
    with their `positions` when given."""
    loo = result.loo

    def where(i: int) -> str:
        return "" if positions is None else f" at {np.round(positions[i], 3).tolist()}"

    if not loo.tested:
        return f"leave-one-out 3D error: not available: {loo.reason}"
    worst = ", ".join(f"#{i + 1} {1e3 * loo.errors[i]:.{digits}f} mm{where(i)}" for i in loo.worst(3))
    return (
        f"leave-one-out 3D error: {1e3 * loo.mean:.{digits + 1}f} mm (mean over {loo.tested} {what})\n"
        f"worst {what} (numbered from 1): {worst}"
    )


def _demo(args: argparse.Namespace) -> int:
    result = run_demo(np.random.default_rng(args.seed or 0))
    if args.json:
        emit(
            {
                "n_points": result.n_points,
                "n_test": result.n_test,
                "sigma_px": result.sigma_px,
                "true_cameras_test_mm": result.true_test_mm,
                "origin_depth_m": result.origin_depth_m,
                "methods": [m.__dict__ for m in result.methods],
            }
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
