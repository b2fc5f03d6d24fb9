"""`wiithrow train`: make the trained-throw library (25 throws labelled by the rig).

    wiithrow train --settings S.json --calibration cal.json [--throws 25] [--out library.json] [--force]
    wiithrow train --sim [--world mujoco|kinematic] [--throws 25] [--out library.json] [--force]
                   [--calibration cal.json] [--recalibrate] [--seed 0]

The shipped library of the simulated PA-10 (throwing/data/pa10_sim_library.json) is made with
`wiithrow train --sim --world kinematic --out throwing/data/pa10_sim_library.json`.

The first line on stderr names the world. `--settings` is the hardware path: the arm, hand and
remotes drivers the settings name (`wiithrow.app.cli.world_choice.hardware_world`, as `wiithrow serve
--settings`; a warning when the arm driver has no passing `wiithrow check-driver` report), the
rig calibrated by `--calibration` (from `wiithrow calibrate --robot --settings S.json`). After each
throw the operator puts the IR marker where the ball first touched down and presses Enter, and the
rig measures it: that is the throw's label (`world_choice.operator_measures_landing`; the MuJoCo
drivers' simulated operator puts the marker down, a script presses Enter by writing a line). The
training targets are `--throws` on a grid over the arm's training area (its spec's,
`throwing.training_area`; 25: the paper's 5 x 5), and the area printed is that arm's.

Before the throws: `--out` is checked (the default `library.json`, which the user did not name,
is not replaced without `--force`), a calibration file is read and checked against the rig, and
in simulation without one the simulated rig's last robot calibration is reused while valid
(`--recalibrate` makes a new one). The library is saved last, after its held-out errors: an
interruption or a failure at any point leaves the old file as it was. A progress bar over the
throws is shown on a terminal (not with --json).

The library is also kept as a new version of the arm's library folder (`--library-folder`, else
the settings' `library_folder`, else beside the calibration; in simulation the world's own), and
compared with the version in use there (held-out error, area, throws:
`wiithrow.app.throws.library_compare`; the table on stderr). It is put in use only by a choice:
`--use`, or `--use-if-better` (when the comparison says it is better; else the library in use stays
and the command says why); otherwise `wiithrow library use N` puts it in use later.

Two held-out figures are printed (`wiithrow.throwing.generalize`), each leaving every trained
throw out in turn and asking the regression for the throw to its measured landing:

* the regression's own held-out error (the paper's leave-one-out): the predicted and the trained
  throw flown by the same model, the distance between their landings. The library's quality: how
  well it generalises to a target it was not trained on.
* the model mismatch: the predicted throw flown by the planner's model against the measured label.
  It adds how far the model's flight is from the world's, which the learning exists to absorb;
  not the library's quality. (MuJoCo world, seed 0: regression 8.1 mm median, 36 mm max, at the
  grid's edges the held-out throw is an extrapolation; model mismatch 5.2 mm median.)
"""

from __future__ import annotations

import argparse
import sys

import numpy as np

from wiithrow.app.cli.arguments import output_file, positive_int, refuse_flags, seed
from wiithrow.app.cli.json_output import emit
from wiithrow.app.cli.library_flags import (
    add_choice_arguments,
    add_library_folder_argument,
    keep_trained_library,
)
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
from wiithrow.app.progress import progress_bar
from wiithrow.app.session import simulated_session
from wiithrow.app.settings import Settings
from wiithrow.app.throws.library_file import save_library
from wiithrow.app.throws.training import train_in_world, training_grid
from wiithrow.app.worlds.base import RigWorld
from wiithrow.throwing import leave_one_out_error, regression_leave_one_out_error, training_area
from wiithrow.vision import StereoCalibration
from wiithrow.vision.stereo_calibration import calibration_fingerprint

NAME = "train"
HELP = "train the throw library: 25 throws, each labelled with its landing as the rig measures it"

DEFAULT_OUT = "library.json"
#: The paper's training: 25 throws, a 5 x 5 grid.
DEFAULT_THROWS = 25


def add_arguments(parser: argparse.ArgumentParser) -> None:
    add_world_arguments(parser, what="train")
    parser.add_argument(
        "--out", help=f"where to write the library (default: {DEFAULT_OUT}, which is not replaced without --force)"
    )
    parser.add_argument("--force", action="store_true", help=f"replace {DEFAULT_OUT} when --out is not given")
    parser.add_argument(
        "--calibration",
        help="calibration JSON to measure with (required with --settings: `wiithrow calibrate --robot --settings`; "
        "default in simulation: the simulated rig's last robot calibration)",
    )
    parser.add_argument("--recalibrate", action="store_true", help="simulation: calibrate with the robot again")
    parser.add_argument(
        "--throws",
        type=positive_int,
        default=DEFAULT_THROWS,
        help=f"training throws, on an NX x NZ grid over the arm's training area (default: {DEFAULT_THROWS}, 5 x 5)",
    )
    parser.add_argument("--seed", type=seed, default=0, help="random seed of the targets' placement (default: 0)")
    parser.add_argument("--json", action="store_true", help="print the result as JSON")
    add_library_folder_argument(parser)
    add_choice_arguments(parser)


def run(args: argparse.Namespace) -> int:
    require_world_choice(args, "train")
    if args.calibration:
        refuse_flags(args, ("recalibrate",), "with --calibration (the file is what is used)")
    if args.settings:
        refuse_flags(args, ("recalibrate",), "with --settings (calibrate with `wiithrow calibrate --robot --settings`)")
        if not args.calibration:
            raise AppError(
                "training on the hardware path measures each landing with the rig: pass --calibration cal.json "
                "(from `wiithrow calibrate --robot --settings S.json`)"
            )
    out = output_file(args, "out", DEFAULT_OUT)
    assert out is not None
    calibration: StereoCalibration | str = "robot"
    if args.calibration:
        calibration = StereoCalibration.load(args.calibration)
    world: RigWorld
    if args.settings:
        assert isinstance(calibration, StereoCalibration)
        world = hardware_world(args, NAME, warn_unchecked=True)
        source = f"{args.calibration} (hardware path, settings {args.settings})"
    else:
        settings = Settings()
        if isinstance(calibration, StereoCalibration):
            check_calibration_file(
                calibration, args.calibration, arm=settings.arm, remotes=settings.rig.count, command=NAME
            )
        say_world(sim_world_line(sim_world_name(args)))
        session = simulated_session(
            world=sim_world_name(args),
            seed=args.seed,
            settings=settings,
            calibration=calibration,
            reuse_calibration=not args.recalibrate,
            say=lambda message: print(f"wiithrow train: {message}", file=sys.stderr),
        )
        world = session.world
        source = args.calibration or "robot, simulated"
    try:
        if isinstance(calibration, StereoCalibration) and args.settings:
            check_calibration_file(
                calibration, args.calibration, arm=world.arm_model.name, remotes=world.settings.rig.count, command=NAME
            )
            world.set_calibration(calibration)
            world.connect()
        library = _train(args, world, source)
        fingerprint = None if world.rig.Ps is None else calibration_fingerprint(world.rig.Ps, "link1")
    finally:
        world.close()
    regression = regression_leave_one_out_error(library)
    loo = leave_one_out_error(library)
    path = save_library(out, library)  # the file first: a version and a choice follow
    kept = keep_trained_library(args, NAME, world, library, regression, fingerprint)
    area = training_area(world.arm_model)
    area_json = {"x_m": list(area.x), "z_m": list(area.z)}
    if args.json:
        emit(
            {
                "library": str(path),
                "world": "hardware" if args.settings else sim_world_name(args),
                "arm": library.arm,
                "throws": len(library.throws),
                "trained_area_throw_plane_link1": area_json,
                "regression_loo_mean_m": regression.mean,
                "regression_loo_median_m": regression.median,
                "regression_loo_max_m": regression.max,
                "model_mismatch_mean_m": loo.mean,
                "model_mismatch_median_m": loo.median,
                "model_mismatch_max_m": loo.max,
                "loo_mean_m": loo.mean,  # the model mismatch, under its former name
                "loo_median_m": loo.median,
                "loo_max_m": loo.max,
                **kept,
            }
        )
    else:
        print(
            f"wrote {path}: {len(library.throws)} throws of arm {library.arm} over x {area.x[0]}-{area.x[1]} m, "
            f"z {area.z[0]}-{area.z[1]} m (link1 throw plane)"
        )
        print(
            f"the regression's held-out error (leave-one-out: the throw predicted for each trained landing without it, "
            f"against the throw that made it, both flown by the model): mean {1e3 * regression.mean:.1f} mm, "
            f"median {1e3 * regression.median:.1f} mm, max {1e3 * regression.max:.1f} mm; "
            "how well the library generalises to a target it was not trained on"
        )
        print(
            f"the model mismatch (the same predicted throws flown by the planner's model, against the measured "
            f"landings): mean {1e3 * loo.mean:.1f} mm, median {1e3 * loo.median:.1f} mm, max {1e3 * loo.max:.1f} mm; "
            "how far the model's flight is from the world's, which the learning absorbs (not the library's quality)"
        )
    return 0


def _train(args: argparse.Namespace, world: RigWorld, calibration_source: str):
    """The training throws in `world`, a progress bar over them on a terminal; on hardware the
    operator marks each landing at the prompt."""
    try:
        targets = training_grid(training_area(world.arm_model), args.throws)
    except ValueError as exc:
        raise AppError(str(exc)) from None
    total = len(targets)
    bar = progress_bar(total=total, desc="training throws", unit="throw", show=not args.json, leave=False)
    done: list[int] = []

    def say(line: str) -> None:
        bar.write(line, file=sys.stderr)

    def on_throw(target, measured):
        done.append(1)
        bar.update(1)
        if not args.json:
            say(
                f"  throw {len(done):2d}/{total}: aimed at x {target[0]:.3f} z {target[1]:.3f} m, "
                f"landed (measured) x {measured[0]:.3f} z {measured[1]:.3f} m (link1)"
            )

    def measure_landing(target):
        what = f"throw {len(done) + 1}/{total} (aimed at x {target[0]:.3f} z {target[1]:.3f} m, link1)"
        return operator_measures_landing(world, what, say=say)

    try:
        return train_in_world(
            world,
            np.random.default_rng(args.seed),
            targets=targets,
            on_throw=on_throw,
            measure_landing=None if world.simulated else measure_landing,
            meta={"seed": args.seed, "calibration": calibration_source},
        )
    finally:
        bar.close()
