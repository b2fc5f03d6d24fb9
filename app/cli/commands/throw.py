"""`wiithrow throw`: track a target, plan, preview, confirm, throw, measure where the ball landed.

    wiithrow throw --target X Y Z --sim [--yes] [--json]
    wiithrow throw --target X Y Z --sim --dry-run --json      (the plan, checkable by anyone)

X Y Z is the simulated IR target's position in `base` (m). The rig measures the target after joint
1 has turned it into the throw plane; the throw is planned to that measurement.
"""

from __future__ import annotations

import argparse
import json
import sys

import numpy as np

from wiithrow.app.errors import AppError
from wiithrow.app.session import DEFAULT_MARGIN_M, Session, ThrowPreview, ThrowRecord, simulated_session
from wiithrow.app.session.simulated import WORLDS
from wiithrow.app.tables import format_table

NAME = "throw"
HELP = "throw the ball at a target: align joint 1, measure, plan, preview, confirm, throw, measure the landing"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--target",
        nargs=3,
        type=float,
        metavar=("X", "Y", "Z"),
        required=True,
        help="the IR target's position in base (m)",
    )
    parser.add_argument("--sim", action="store_true", help="the simulated arm, rig and ball")
    parser.add_argument("--dry-run", action="store_true", help="plan and preview only; the arm does not throw")
    parser.add_argument("--yes", action="store_true", help="throw without asking for confirmation")
    parser.add_argument("--json", action="store_true", help="print the plan (with --dry-run) or the result as JSON")
    parser.add_argument("--calibration", help="calibration JSON (default in simulation: calibrate with the robot now)")
    parser.add_argument("--library", help="throw library JSON (default: the shipped library of the simulated PA-10)")
    parser.add_argument(
        "--margin",
        type=float,
        default=DEFAULT_MARGIN_M,
        help=f"how far (m) outside the trained area a target may be (default: {DEFAULT_MARGIN_M})",
    )
    parser.add_argument(
        "--world",
        choices=WORLDS,
        default="kinematic",
        help="the simulated world: mujoco (physics the planner does not know) or kinematic (its own models) (default: kinematic)",
    )
    parser.add_argument("--seed", type=int, default=0, help="random seed of the simulation (default: 0)")


def run(args: argparse.Namespace) -> int:
    if not args.sim:
        raise AppError("throwing with a real arm needs an arm driver, and this installation has none: use --sim")
    target = np.array(args.target, dtype=float)
    if not np.isfinite(target).all():
        raise AppError(f"--target must be three finite numbers, got {args.target}")
    session = simulated_session(
        seed=args.seed, calibration=args.calibration or "robot", library=args.library, quiet=args.json
    )
    session.margin_m = args.margin
    session.set_target(target)
    alignment = session.align()
    if not alignment.converged:
        raise AppError(f"could not align joint 1 to the target: {alignment.message}")
    preview = session.plan_preview(margin_m=args.margin)
    ball_offset = session.world.settings.ball.offset_m
    if args.dry_run:
        if args.json:
            print(json.dumps(preview.to_dict(ball_offset)))
        else:
            _print_preview(session, preview)
        return 0
    if not args.json:
        _print_preview(session, preview)
    if not args.yes and not _confirm():
        print("not thrown", file=sys.stderr)
        return 1
    record = session.throw(preview.id)
    if args.json:
        print(json.dumps(_result(record)))
    else:
        _print_result(record)
    return 0


def _confirm() -> bool:
    if not sys.stdin.isatty():
        raise AppError("the throw needs a confirmation: run it in a terminal, or pass --yes")
    return input("Throw? [y/N] ").strip().lower() in ("y", "yes")


def _print_preview(session: Session, preview: ThrowPreview) -> None:
    names = session.world.arm_model.joint_names
    print(
        f"target in the throw plane: x {preview.target_xz[0]:.3f} m, z {preview.target_xz[1]:.3f} m "
        f"(joint 1 at {np.degrees(preview.q1):.2f} deg)"
    )
    print(
        f"predicted landing: x {preview.predicted_xz[0]:.3f} m, z {preview.predicted_xz[1]:.3f} m; "
        f"trajectory {preview.duration_s:.2f} s, release at {preview.throw.release_time:.3f} s"
    )
    rows = [
        (n, float(s), float(v), f"{100 * r:.0f}%")
        for n, s, v, r in zip(names, preview.peak_speed, preview.velocity_limit, preview.speed_ratio)
    ]
    print(format_table(["joint", "peak rad/s", "limit rad/s", "of limit"], rows))


def _result(record: ThrowRecord) -> dict:
    return {
        "target_throw_plane_m": record.target_xz.tolist(),
        "landing_measured_throw_plane_m": record.landing_xz.tolist(),
        "predicted_throw_plane_m": record.predicted_xz.tolist(),
        "error_m": record.error_m,
        "true_error_m": record.true_error_m,
        "landing_true_base_m": record.execution.landing_base.tolist(),
    }


def _print_result(record: ThrowRecord) -> None:
    print(
        f"landed (measured by the rig): x {record.landing_xz[0]:.3f} m, z {record.landing_xz[1]:.3f} m; "
        f"error {1e3 * record.error_m:.1f} mm"
    )
    if record.true_error_m is not None:
        print(f"(simulation truth: the ball landed {1e3 * record.true_error_m:.1f} mm from the target)")
