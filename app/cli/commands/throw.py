"""`wiithrow throw`: track a target, plan, preview, confirm, throw, measure where the ball landed.

    wiithrow throw --settings S.json --calibration cal.json [--library lib.json] [--yes] [--json]
    wiithrow throw --target X Y Z --sim [--world mujoco|kinematic] [--yes] [--json]
    wiithrow throw --target X Y Z --sim --dry-run --json      (the plan, checkable by anyone)

The first line on stderr names the world. With `--settings` (the hardware path) the arm, hand and
remotes are the drivers the settings name (`wiithrow.app.cli.world_choice.hardware_world`, as
`wiithrow serve --settings`; a warning when the arm driver has no passing `wiithrow check-driver`
report), the target is the IR source the operator put down (the rig finds it: no `--target`),
the rig is calibrated by `--calibration` (else the newest hardware calibration in the current folder
made with these settings: `wiithrow.app.cli.calibration_choice`), and after the throw the operator puts the IR marker where
the ball first touched down and presses Enter: the rig measures it, and the error printed is the
rig's (landing against target, both measured, in 3D: the total on the landing surface, and along
and across the throw, `wiithrow.throwing.landing_error`). The MuJoCo drivers' lab puts its target at the
settings' `mujoco.target_base` and its simulated operator puts the marker down.

In simulation X Y Z is the simulated IR target's position in `base` (m). Joint 1 turns the target into the
throw plane, the rig measures it there as (x, z) in `link1` (distance from the joint-1 axis,
height), and the throw is planned to that measurement; what is printed names its frame.

Inputs are checked before the minute of calibration: the library (it must be trained for this
arm), a calibration file (it must fit the rig: its cameras, link1, made on this arm), and the
target (one no throw of the arm can reach, `throwing.reach`, is one line before anything else;
one clearly outside the trained area is refused from its nominal position; one near the edge is judged on
the rig's measurement; one whose azimuth joint 1 cannot turn to, behind the arm, is refused
before anything moves). Without `--calibration` the rig measures with the newest calibration file
in the current folder made for this arm in this world (what `wiithrow calibrate --robot --sim`
wrote there), else the simulated rig's last robot calibration, reused while valid
(`wiithrow.app.calibration.simulated`; `--recalibrate` makes a new one): one line on stderr says
which and why (`wiithrow.app.cli.calibration_choice`), and one line names the library
(`library_flags.library_in_use`).

The library is the library folder's version in use (`--library-folder`, else the settings'
`library_folder`, else beside the calibration; in simulation a folder of the world's own:
`wiithrow.app.session.library_folder`), else the shipped one; `--library FILE` is kept as a version
of the folder and put in use (not on a dry run); a version trained with another calibration than
the one the command measures with is said in one line. A measured throw that joins the library
makes a new version of it (`wiithrow.app.throws.learning`); the file is never written.

`--json` prints one document whatever the mode: the library (`library`: {"source": "version",
"file" or "shipped", "version", "folder", "file"}) and the calibration (`calibration`: {"file",
"chosen": "given", "newest", "recalibrate" or "simulated", "fingerprint"}) it throws with, the
plan's keys (`ThrowPreview.to_dict`; the joint positions at every control step only with
`--trajectory`), the target as given
(`target_base_m`), `thrown`, and `result` (null for a dry run, else the measured landing:
`ThrowRecord.to_dict`: `error` and, in simulation, `true_error`, each {"along_m", "across_m",
"height_m", "total_m"}; `error_m` and `true_error_m` their totals). Points in the throw plane are
{"x", "z"} objects under keys ending `_throw_plane_link1_m`; points in base are [x, y, z] under
keys ending `_base_m`.
"""

from __future__ import annotations

import argparse
import sys
from typing import Any

import numpy as np

from wiithrow.app.cli.arguments import (
    add_learn_argument,
    finite_float,
    non_negative_float,
    refuse_flags,
    seed,
)
from wiithrow.app.cli.calibration_choice import CalibrationChoice, choose_calibration, required_on_hardware
from wiithrow.app.cli.json_output import emit
from wiithrow.app.cli.library_flags import add_library_arguments, library_in_use, store_from_args
from wiithrow.app.cli.world_choice import (
    add_world_arguments,
    check_calibration_file,
    hardware_world,
    operator_measures_landing,
    require_world_choice,
    say_world,
    sim_world_line,
    sim_world_name,
)
from wiithrow.app.errors import AppError
from wiithrow.app.session import DEFAULT_MARGIN_M, Session, ThrowPreview, ThrowRecord, simulated_session
from wiithrow.app.session.library_folder import starting_library
from wiithrow.app.session.library_use import calibration_note
from wiithrow.app.settings import Settings
from wiithrow.app.tables import format_table
from wiithrow.app.throws.library_file import load_library
from wiithrow.robot import ArmModel
from wiithrow.throwing import ThrowLibrary
from wiithrow.throwing.generalize import TrainedArea
from wiithrow.throwing.reach import check_target_reach
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
        help="--sim: the simulated IR target's position in base (m); on hardware the rig finds the target",
    )
    add_world_arguments(parser, what="throw")
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
        help="calibration JSON to measure with (default: the newest calibration file in this folder made for this arm "
        "in this world, by `wiithrow calibrate --robot`; else in simulation the simulated rig's last robot calibration)",
    )
    parser.add_argument("--recalibrate", action="store_true", help="simulation: calibrate with the robot again")
    add_library_arguments(parser, shipped="the shipped library of the simulated PA-10")
    add_learn_argument(parser)
    parser.add_argument(
        "--margin",
        type=non_negative_float,
        default=DEFAULT_MARGIN_M,
        help=f"how far (m) outside the trained area a target may be (default: {DEFAULT_MARGIN_M})",
    )
    parser.add_argument("--seed", type=seed, default=0, help="random seed of the simulation (default: 0)")


def run(args: argparse.Namespace) -> int:
    require_world_choice(args, "throw")
    if args.settings:
        refuse_flags(args, ("target",), "with --settings (the target is the IR source you put down: the rig finds it)")
        refuse_flags(args, ("recalibrate",), "with --settings (calibrate with `wiithrow calibrate --robot --settings`)")
    elif args.target is None:
        raise AppError("give the simulated target: --target X Y Z (m, in base)")
    if args.dry_run:
        refuse_flags(args, ("yes",), "to --dry-run (nothing is thrown)")
    if args.calibration:
        refuse_flags(args, ("recalibrate",), "with --calibration (the file is what is used)")
    if not args.json:
        refuse_flags(args, ("trajectory",), "without --json (it is a part of the JSON document)")
    if args.settings:
        return _on_hardware(args)
    target = np.array(args.target, dtype=float)
    settings = Settings()
    store = store_from_args(args, NAME, arm=settings.arm, world=sim_world_name(args))
    given, version = starting_library(store, args.library, settings.arm, _say, keep=not args.dry_run)
    library = given if given is not None else load_library()
    library.require_arm(settings.arm)
    arm = settings.load_arm()
    check_target_reach(arm, target)
    precheck_joint1(arm, target)
    choice = choose_calibration(
        given=args.calibration,
        recalibrate=args.recalibrate,
        arm=arm.name,
        remotes=settings.rig.count,
        world=sim_world_name(args),
    )
    calibration: StereoCalibration | str = "robot"
    if choice.calibration is not None:
        calibration = check_calibration_file(
            choice.calibration, str(choice.path), arm=arm.name, remotes=settings.rig.count, command=NAME
        )
    precheck_target(library, target, args.margin)
    library_line, library_keys = library_in_use(store, args.library, version)
    say_world(sim_world_line(sim_world_name(args)))
    for line in (*choice.lines, library_line):
        _say(line)
    session = simulated_session(
        world=sim_world_name(args),
        seed=args.seed,
        settings=settings,
        calibration=calibration,
        library=given,
        store=store,
        version=version,
        reuse_calibration=not args.recalibrate,
        learn=not args.no_learn,
        say=_say,
    )
    session.margin_m = args.margin
    session.set_target(target)
    return _align_plan_throw(args, session, target.tolist(), choice, library_keys)


def _say(message: str) -> None:
    print(f"wiithrow throw: {message}", file=sys.stderr)


def _align_plan_throw(
    args: argparse.Namespace,
    session: Session,
    target_base: list[float] | None,
    choice: CalibrationChoice,
    library: dict[str, Any],
) -> int:
    """Align joint 1 to the target, preview, confirm, throw; on hardware the operator then marks
    the landing and the rig measures it. `target_base`: the target as given (None on hardware);
    `choice` and `library`: the calibration and the library the throw is made with, for --json."""
    alignment = session.align()
    if not alignment.converged:
        raise AppError(f"could not align joint 1 to the target: {alignment.message}")
    preview = session.plan_preview(margin_m=args.margin)
    note = calibration_note(session.library_version, session.calibration_fingerprint())
    if note:  # a library trained with another calibration: one line
        _say(note)
    plan = {
        "library": library,
        "calibration": choice.to_dict(session.calibration_fingerprint()),
        "target_base_m": target_base,
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
    record = session.throw(preview.id)  # a failed throw raises, saying why, the arm at rest
    if not session.world.simulated and not np.isfinite(record.landing_xz).all():
        record = _measured_by_the_operator(session)
    if args.json:
        emit({**plan, "thrown": True, "result": record.to_dict()})
    else:
        _print_result(record)
    return 0


def _measured_by_the_operator(session: Session) -> ThrowRecord:
    """The operator marks the landing (the prompt), the session measures it (*Measure landing*)."""
    measured: list[ThrowRecord] = []

    def measure() -> np.ndarray:
        measured.append(session.measure_landing())  # AppError when the rig sees no marker: asked again
        return measured[-1].execution.measured_link1

    # the session's loop reads the rig meanwhile (session.start)
    operator_measures_landing(session.world, "the throw", measure=measure, keep_reading=False)
    return measured[-1]


def _on_hardware(args: argparse.Namespace) -> int:
    """`throw --settings`: the drivers the settings name, the target the rig finds (module docstring)."""
    settings = Settings.load(args.settings)
    choice = choose_calibration(
        given=args.calibration,
        recalibrate=False,
        arm=settings.arm,
        remotes=settings.rig.count,
        world=None,
        settings_path=args.settings,
    )
    calibration = required_on_hardware(
        choice, "throwing on the hardware path tracks the target with the rig", settings.arm
    )
    store = store_from_args(
        args,
        NAME,
        arm=settings.arm,
        settings_folder=settings.library_folder,
        settings_path=args.settings,
        calibration_path=choice.path,
    )
    given, version = starting_library(store, args.library, settings.arm, _say, keep=not args.dry_run)
    library_line, library_keys = library_in_use(store, args.library, version)
    world = hardware_world(args, NAME, warn_unchecked=True)
    for line in (*choice.lines, library_line):
        _say(line)
    session = Session(
        world,
        library=given,
        rng=np.random.default_rng(args.seed),
        learn=not args.no_learn,
        store=store,
        version=version,
    )
    try:  # closing the session closes the world
        session.library.require_arm(world.settings.arm)
        check_calibration_file(
            calibration, str(choice.path), arm=world.arm_model.name, remotes=world.settings.rig.count, command=NAME
        )
        session.use_calibration(calibration)
        session.margin_m = args.margin
        session.start()  # the rig is read while no operation runs, as the dashboard's session is
        return _align_plan_throw(args, session, None, choice, library_keys)
    finally:
        session.close()


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
    """The landing as the rig measured it, its error (landing against the measured target)."""
    print(
        f"landed (measured by the rig, link1): x {record.landing_xz[0]:.3f} m, z {record.landing_xz[1]:.3f} m; "
        f"error {record.error.words('mm')}"
    )
    if record.true_error is not None:
        print(f"(simulation truth: the ball landed {record.true_error.words('mm')} from the target)")
