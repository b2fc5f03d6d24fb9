"""`wiithrow throw`: track a target, plan, preview, confirm, throw, measure where the ball landed.

    wiithrow throw --target X Y Z --sim [--yes] [--json]
    wiithrow throw --target X Y Z --sim --dry-run --json      (the plan, checkable by anyone)

X Y Z is the simulated IR target's position in `base` (m). Joint 1 turns the target into the
throw plane, the rig measures it there as (x, z) in `link1` (distance from the joint-1 axis,
height), and the throw is planned to that measurement; what is printed names its frame.

Inputs are checked before the minute of calibration: the library (it must be trained for this
arm), a calibration file (it must fit the rig: its cameras, link1), and the target (one clearly
outside the trained area is refused from its nominal position; one near the edge is judged on
the rig's measurement; one whose azimuth joint 1 cannot turn to, behind the arm, is refused
before anything moves). Without `--calibration` the simulated rig's last robot calibration is
reused while valid (`wiithrow.app.calibration.simulated`; `--recalibrate` makes a new one).

`--json` prints one document whatever the mode: the plan's keys (`ThrowPreview.to_dict`; the
joint positions at every control step only with `--trajectory`), the target as given
(`target_base_m`), `thrown`, and `result` (null for a dry run, else the measured landing:
`ThrowRecord.to_dict`). Points in the throw plane are {"x", "z"} objects under keys
ending `_throw_plane_link1_m`; points in base are [x, y, z] under keys ending `_base_m`.
"""

from __future__ import annotations

import argparse
import sys

import numpy as np

from wiithrow.app.cli.arguments import (
    add_learn_argument,
    add_world_argument,
    finite_float,
    non_negative_float,
    refuse_flags,
    seed,
)
from wiithrow.app.cli.json_output import emit
from wiithrow.app.errors import AppError
from wiithrow.app.session import DEFAULT_MARGIN_M, Session, ThrowPreview, ThrowRecord, simulated_session
from wiithrow.app.settings import Settings
from wiithrow.app.tables import format_table
from wiithrow.app.throws.library_file import load_library
from wiithrow.app.worlds.base import check_calibration_fits
from wiithrow.robot import ArmModel
from wiithrow.throwing import ThrowLibrary
from wiithrow.throwing.generalize import TrainedArea
from wiithrow.vision import StereoCalibration

NAME = "throw"
HELP = "throw the ball at a target: align joint 1, measure, plan, preview, confirm, throw, measure the landing"

#: A target whose nominal (x, z) lies farther than this beyond the allowed margin is refused
#: before calibrating; the rig measures targets within millimetres, so a closer one is judged on
#: its measurement.
PRECHECK_SLACK_M = 0.05


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--target",
        nargs=3,
        type=finite_float,
        metavar=("X", "Y", "Z"),
        required=True,
        help="the IR target's position in base (m)",
    )
    parser.add_argument("--sim", action="store_true", help="the simulated arm, rig and ball")
    parser.add_argument("--dry-run", action="store_true", help="plan and preview only; the arm does not throw")
    parser.add_argument("--yes", action="store_true", help="throw without asking for confirmation")
    parser.add_argument("--json", action="store_true", help="print the plan (and the result) as one JSON document")
    parser.add_argument(
        "--trajectory",
        action="store_true",
        help="with --json: include the joint positions at every control step (about 200 KB a throw)",
    )
    parser.add_argument(
        "--calibration",
        help="calibration JSON (default in simulation: the simulated rig's last robot calibration, or a new one)",
    )
    parser.add_argument("--recalibrate", action="store_true", help="simulation: calibrate with the robot again")
    parser.add_argument("--library", help="throw library JSON (default: the shipped library of the simulated PA-10)")
    add_learn_argument(parser)
    parser.add_argument(
        "--margin",
        type=non_negative_float,
        default=DEFAULT_MARGIN_M,
        help=f"how far (m) outside the trained area a target may be (default: {DEFAULT_MARGIN_M})",
    )
    add_world_argument(parser, "kinematic")
    parser.add_argument("--seed", type=seed, default=0, help="random seed of the simulation (default: 0)")


def run(args: argparse.Namespace) -> int:
    if not args.sim:
        raise AppError("throwing with a real arm needs an arm driver, and this installation has none: use --sim")
    if args.dry_run:
        refuse_flags(args, ("yes",), "to --dry-run (nothing is thrown)")
    if args.calibration:
        refuse_flags(args, ("recalibrate",), "with --calibration (the file is what is used)")
    if not args.json:
        refuse_flags(args, ("trajectory",), "without --json (it is a part of the JSON document)")
    target = np.array(args.target, dtype=float)
    settings = Settings()
    library = load_library(args.library)
    library.require_arm(settings.arm)
    precheck_joint1(settings.load_arm(), target)
    calibration: StereoCalibration | str = "robot"
    if args.calibration:
        calibration = StereoCalibration.load(args.calibration)
        check_calibration_fits(calibration, remotes=settings.rig.count, frame="link1")
    precheck_target(library, target, args.margin)
    session = simulated_session(
        world=args.world,
        seed=args.seed,
        settings=settings,
        calibration=calibration,
        library=args.library if args.library else library,
        reuse_calibration=not args.recalibrate,
        learn=not args.no_learn,
        say=lambda message: print(f"wiithrow throw: {message}", file=sys.stderr),
    )
    session.margin_m = args.margin
    session.set_target(target)
    alignment = session.align()
    if not alignment.converged:
        raise AppError(f"could not align joint 1 to the target: {alignment.message}")
    preview = session.plan_preview(margin_m=args.margin)
    plan = {
        "target_base_m": target.tolist(),
        **preview.to_dict(session.world.settings.ball.offset_m, trajectory=args.trajectory),
    }
    if not args.json:
        _print_preview(session, preview)
    if args.dry_run:
        if args.json:
            emit({**plan, "thrown": False, "result": None})
        return 0
    if not args.yes and not _confirm():
        print("wiithrow throw: not thrown", file=sys.stderr)
        return 1
    record = session.throw(preview.id)
    if args.json:
        emit({**plan, "thrown": True, "result": record.to_dict()})
    else:
        _print_result(record)
    return 0


def precheck_target(library: ThrowLibrary, target_base: np.ndarray, margin_m: float) -> None:
    """OutsideTrainedAreaError (as the planner words it) for a target whose nominal throw-plane
    position, (distance from the joint-1 axis, height), is clearly outside the trained area."""
    area = TrainedArea(library.landings)
    xz = np.array([np.hypot(target_base[0], target_base[1]), target_base[2]])
    if area.distance_outside(xz) > margin_m + PRECHECK_SLACK_M:
        area.check(xz, margin_m)


def precheck_joint1(arm: ArmModel, target_base: np.ndarray) -> None:
    """AppError for a target that joint 1 cannot turn the throw plane to: the plane holds the
    joint-1 axis, so the target's azimuth psi = atan2(y, x) in base (or psi +- 2 pi) must lie within
    joint 1's limits; a target on the axis has no azimuth."""
    x, y = float(target_base[0]), float(target_base[1])
    if np.hypot(x, y) < 1e-3:
        raise AppError("the target is on joint 1's axis: the throw plane cannot be turned to it")
    psi = float(np.arctan2(y, x))
    lower, upper = float(arm.lower[0]), float(arm.upper[0])
    if not any(lower <= psi + k * 2 * np.pi <= upper for k in (-1, 0, 1)):
        raise AppError(
            f"the target is at azimuth {np.degrees(psi):.1f} deg in base, beyond the range joint 1 "
            f"({arm.joint_names[0]}) turns, {np.degrees(lower):.0f} to {np.degrees(upper):.0f} deg: "
            "it is behind the arm; put it in front"
        )


def _confirm() -> bool:
    if not sys.stdin.isatty():
        raise AppError("the throw needs a confirmation: run it in a terminal, or pass --yes")
    return input("Throw? [y/N] ").strip().lower() in ("y", "yes")


def _print_preview(session: Session, preview: ThrowPreview) -> None:
    names = session.world.arm_model.joint_names
    print(
        f"target in the throw plane (link1, as the rig measured it): x {preview.target_xz[0]:.3f} m, "
        f"z {preview.target_xz[1]:.3f} m (joint 1 at {np.degrees(preview.q1):.2f} deg)"
    )
    print(
        f"predicted landing (link1): x {preview.predicted_xz[0]:.3f} m, z {preview.predicted_xz[1]:.3f} m; "
        f"trajectory {preview.duration_s:.2f} s, release at {preview.throw.release_time:.3f} s"
    )
    rows = [
        (n, float(s), float(v), f"{100 * r:.0f}%")
        for n, s, v, r in zip(names, preview.peak_speed, preview.velocity_limit, preview.speed_ratio)
    ]
    print(format_table(["joint", "peak rad/s", "limit rad/s", "of limit"], rows))


def _print_result(record: ThrowRecord) -> None:
    print(
        f"landed (measured by the rig, link1): x {record.landing_xz[0]:.3f} m, z {record.landing_xz[1]:.3f} m; "
        f"error {1e3 * record.error_m:.1f} mm"
    )
    if record.true_error_m is not None:
        print(f"(simulation truth: the ball landed {1e3 * record.true_error_m:.1f} mm from the target)")
