"""`wiithrow train`: make the trained-throw library (25 throws labelled by the rig).

    wiithrow train --settings S.json [--calibration cal.json] [--throws 25] [--out library.json] [--force]
                   [--resume] [--on-lost ask|retry|skip|stop]
    wiithrow train --sim [--world mujoco|kinematic] [--throws 25] [--out library.json] [--force]
                   [--calibration cal.json] [--recalibrate] [--seed 0] [--resume] [--on-lost ...]

The first line on stderr names the world. `--settings` is the hardware path: the arm, hand and
remotes drivers the settings name (`wiithrow.app.cli.world_choice.hardware_world`, as `wiithrow serve
--settings`; a warning when the arm driver has no passing `wiithrow check-driver` report), the
rig calibrated by `--calibration` (from `wiithrow calibrate --robot --settings S.json`; without it,
the newest such calibration in the current folder).

The run is the dashboard's Training panel's (`wiithrow.app.throws.training_run.TrainingRun`,
through the session's training steps: `wiithrow.app.cli.train_steps`): `--throws` targets over the
arm's training area (its spec's, `throwing.training_area`, bounded by the arm's reach; 25: the
paper's 5 x 5), each thrown from the home pose and labelled by the rig's measurement of the landing
marker. Before the first throw the calibrated rig must see the area with 10 cm around it
(`wiithrow.app.throws.area_view`: one line names the corner it does not see and what to change). On
the hardware path the operator puts the IR marker where the ball first touched down, covers the
target and presses Enter at the prompt, which appears once the ball is down and takes only a line
written after it (`world_choice.landing_prompt`; the MuJoCo drivers' simulated operator puts the
marker down, a script presses Enter by writing a line after it reads the prompt); in simulation the
world's simulated operator puts it down.

The progress is saved after every step beside the library, `<out stem>.training.json`
(`training_file`): a throw whose landing the rig does not see, whose ball was lost, or that failed
in any way is marked failed, and then retried, skipped or the run stopped: asked at a terminal
("r retry / s skip / q stop"), or as `--on-lost` says (`retry`: at most
`train_steps.RETRIES_PER_TARGET` retries per target, then skipped; off a terminal the default is
`stop`). A stop (exit status 1), an error (2) or Ctrl-C (130) keeps every measured throw in the
progress file and says how to resume, in one line; `--resume` takes the run up where it was (its
targets are the file's: no `--throws`; a failed throw there is decided again), and a run found
there without `--resume` is refused in one line, never overwritten. Finishing fits the measured
throws (at least 5), saves the library and removes the progress file.

Before the throws: `--out` is checked (the default `library.json`, which the user did not name,
is not replaced without `--force`), and the calibration is chosen
(`wiithrow.app.cli.calibration_choice`, said in one line on stderr after the world line):
`--calibration`, else the newest calibration file in the current folder made for this arm in this
world (what `wiithrow calibrate --robot` wrote there: `--sim` in the same simulated world, or
`--settings` with the same settings), else in simulation the simulated rig's last robot
calibration, reused while valid (`--recalibrate` makes a new one); a file is read and checked
against the rig. The library is saved last, after its held-out errors: an
interruption or a failure at any point leaves the old file as it was (and the progress file, to
resume). A progress bar over the throws is shown on a terminal (not with --json).

The shipped library of the simulated PA-10 (throwing/data/pa10_sim_library.json) was made by the
procedure this command ran before it ran the panel's (`wiithrow.app.throws.training.train_in_world`,
targets placed with 1 cm of seeded jitter); `wiithrow train --sim --world kinematic` makes one of
the same quality.

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
from pathlib import Path
from typing import Any

import numpy as np

from wiithrow.app.cli.arguments import output_file, positive_int, refuse_flags, seed
from wiithrow.app.cli.calibration_choice import choose_calibration, required_on_hardware
from wiithrow.app.cli.json_output import emit
from wiithrow.app.cli.library_flags import (
    add_choice_arguments,
    add_library_folder_argument,
    print_comparison,
    store_from_args,
    use_from_args,
)
from wiithrow.app.cli.operator_input import OperatorInput
from wiithrow.app.cli.train_steps import ON_LOST, FailedThrows, TrainingStopped, throw_the_run
from wiithrow.app.cli.world_choice import (
    add_world_arguments,
    check_calibration_file,
    hardware_world,
    require_world_choice,
    say_world,
    sim_world_line,
    sim_world_name,
)
from wiithrow.app.errors import AppError, expected_errors
from wiithrow.app.progress import progress_bar
from wiithrow.app.session import Session, simulated_session
from wiithrow.app.session.library_folder import starting_library
from wiithrow.app.settings import Settings
from wiithrow.app.throws.area_view import require_area_in_view
from wiithrow.app.throws.training_file import load_run, progress_path
from wiithrow.app.throws.training_run import (
    DEFAULT_THROWS,
    MIN_MEASURED,
    TrainingOutcome,
    TrainingRun,
    library_of,
)
from wiithrow.throwing import leave_one_out_error, training_area
from wiithrow.throwing.generalize import LeaveOneOutResult
from wiithrow.vision import StereoCalibration

NAME = "train"
HELP = "train the throw library: 25 throws, each labelled with its landing as the rig measures it"

DEFAULT_OUT = "library.json"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    add_world_arguments(parser, what="train")
    parser.add_argument(
        "--out", help=f"where to write the library (default: {DEFAULT_OUT}, which is not replaced without --force)"
    )
    parser.add_argument("--force", action="store_true", help=f"replace {DEFAULT_OUT} when --out is not given")
    parser.add_argument(
        "--calibration",
        help="calibration JSON to measure with (default: the newest calibration file in this folder made for this arm "
        "in this world, by `wiithrow calibrate --robot`; else in simulation the simulated rig's last robot calibration)",
    )
    parser.add_argument("--recalibrate", action="store_true", help="simulation: calibrate with the robot again")
    parser.add_argument(
        "--throws",
        type=positive_int,
        help=f"training throws over the arm's training area, 5 to 100 (default: {DEFAULT_THROWS}, the paper's 5 x 5)",
    )
    parser.add_argument(
        "--resume",
        action="store_true",
        help="take up the run saved beside --out (<out>.training.json) where it stopped",
    )
    parser.add_argument(
        "--on-lost",
        choices=ON_LOST,
        help="what to do with a throw whose landing is not seen, whose ball was lost or that failed: ask (the "
        "default on a terminal), retry (at most twice per target, then skip it), skip, stop (the default off a "
        "terminal; the run is kept for --resume)",
    )
    parser.add_argument("--seed", type=seed, default=0, help="random seed of the simulated world (default: 0)")
    parser.add_argument("--json", action="store_true", help="print the result as JSON")
    add_library_folder_argument(parser)
    add_choice_arguments(parser)


def run(args: argparse.Namespace) -> int:
    require_world_choice(args, "train")
    if args.calibration:
        refuse_flags(args, ("recalibrate",), "with --calibration (the file is what is used)")
    if args.resume:
        refuse_flags(args, ("throws",), "with --resume (the run's targets are in its progress file)")
    if args.settings:
        refuse_flags(args, ("recalibrate",), "with --settings (calibrate with `wiithrow calibrate --robot --settings`)")
    out = output_file(args, "out", DEFAULT_OUT)
    assert out is not None
    check_progress(out, args.resume)
    settings = Settings.load(args.settings) if args.settings else Settings()
    choice = choose_calibration(
        given=args.calibration,
        recalibrate=args.recalibrate,
        arm=settings.arm,
        remotes=settings.rig.count,
        world=None if args.settings else sim_world_name(args),
        settings_path=args.settings,
    )
    if args.settings:
        required_on_hardware(choice, "training on the hardware path measures each landing with the rig", settings.arm)
    calibration: StereoCalibration | str = choice.calibration if choice.calibration is not None else "robot"
    session: Session
    if args.settings:
        assert isinstance(calibration, StereoCalibration)
        hardware = hardware_world(args, NAME, warn_unchecked=True)
        _say_lines(choice.lines)
        store = store_from_args(
            args,
            NAME,
            arm=hardware.arm_model.name,
            settings_folder=hardware.settings.library_folder,
            settings_path=args.settings,
            calibration_path=choice.path,
        )
        library, version = starting_library(store, None, hardware.arm_model.name, _say)
        session = Session(hardware, library=library, rng=np.random.default_rng(args.seed), store=store, version=version)
    else:
        if isinstance(calibration, StereoCalibration):
            check_calibration_file(
                calibration, str(choice.path), arm=settings.arm, remotes=settings.rig.count, command=NAME
            )
        say_world(sim_world_line(sim_world_name(args)))
        _say_lines(choice.lines)
        session = simulated_session(
            world=sim_world_name(args),
            seed=args.seed,
            settings=settings,
            calibration=calibration,
            reuse_calibration=not args.recalibrate,
            say=_say,
            store=store_from_args(args, NAME, arm=settings.arm, world=sim_world_name(args)),
        )
    try:  # closing the session closes the world
        world = session.world
        if isinstance(calibration, StereoCalibration) and args.settings:
            check_calibration_file(
                calibration, str(choice.path), arm=world.arm_model.name, remotes=world.settings.rig.count, command=NAME
            )
            session.use_calibration(calibration)
            session.start()  # the rig is read while no step runs (the operator's prompts), as the dashboard's
        return _train(args, session, out)
    finally:
        session.close()


def _say_lines(lines: tuple[str, ...]) -> None:
    for line in lines:
        _say(line)


def check_progress(out: Path, resume: bool) -> None:
    """A run saved beside `out` is taken up only with --resume (refused otherwise, in one line saying
    how to resume or discard it: never overwritten); --resume needs one."""
    path = progress_path(out)
    if resume and not path.exists():
        raise AppError(f"--resume: no training run in progress beside {out} (no {path}): start without --resume")
    if not resume and path.exists():
        saved = load_run(path, out)  # a broken file: its own one line
        held = f" ({saved.measured} of {saved.count} measured)" if saved is not None else ""
        raise AppError(
            f"{path} holds a training run in progress{held}: add --resume to take it up, or remove it to start again"
        )


def _train(args: argparse.Namespace, session: Session, out: Path) -> int:
    """Start (or resume) the run, throw it, fit and save the library; a run that stops or fails on
    the way is kept beside `out` and the line says how to resume it."""
    world = session.world
    resumed = session.train_to(out)
    if resumed is not None:
        require_area_in_view(resumed.area, world.rig.Ps, world.rig.camera_names)  # the rig may have moved since
        print(f"wiithrow train: resumed {progress_path(out)}: {resumed.progress_line()}", file=sys.stderr)
    else:
        run = session.start_training(training_area(world.arm_model), args.throws or DEFAULT_THROWS)
        for note in run.notes:
            print(f"wiithrow train: {note}", file=sys.stderr)
    try:
        run = _throws(args, session)
        library = library_of(run, world.arm_model, world.ball())
        with session.rig_loop_paused():  # before the save: an interruption keeps the old file
            loo = leave_one_out_error(library, world.arm_model)
        outcome = session.finish_training(by="command")  # kept as a version; the flags choose below
        kept = _choose(args, session, outcome)
    except TrainingStopped as stopped:
        print(f"wiithrow train: {_kept(session, out, f'stopped ({stopped.reason})')}", file=sys.stderr)
        return 1
    except KeyboardInterrupt:
        print(f"wiithrow train: {_kept(session, out, 'interrupted')}", file=sys.stderr)
        return 130
    except expected_errors() as exc:
        raise AppError(_kept(session, out, str(exc))) from None
    except Exception:
        print(f"wiithrow train: {_kept(session, out, 'failed')}", file=sys.stderr)
        raise
    _report(args, outcome, loo, run, kept)
    return 0


def _say(message: str) -> None:
    print(f"wiithrow train: {message}", file=sys.stderr)


def _choose(args: argparse.Namespace, session: Session, outcome: TrainingOutcome) -> dict[str, Any]:
    """The trained library, kept as a version by Finish, put in use as the flags choose
    (`library_flags.use_from_args`: `--use`, `--use-if-better`, else kept, not in use); the
    comparison with the library in use on stderr; the JSON keys that say so."""
    choice = session.snapshot().library_choice
    if choice is None:  # (Finish always leaves one to choose)
        return {}
    use = use_from_args(args)
    used: bool | None = None
    if use == "always" or (use == "if_better" and choice.comparison.better):
        session.choose_trained_library(True, by="command")
        used = True
    elif use == "if_better":
        session.choose_trained_library(False, by="command")
        used = False
    store = session.library_store
    folder = store.folder if store is not None else None
    print_comparison(choice.comparison, used, outcome.version, folder)
    return {
        "library_folder": None if folder is None else str(folder),
        "version": outcome.version,
        "in_use": used is True,
        "comparison": choice.comparison.to_dict(),
    }


def _kept(session: Session, out: Path, why: str) -> str:
    """`why`, and what the progress file keeps, and how to go on."""
    run = session.snapshot().training
    if run is None or not progress_path(out).exists():
        return why
    where = f"at throw {run.index + 1}/{run.count}" if run.index is not None else "with every throw done"
    n = run.measured
    kept = f"{why} {where}: {n} measured throw{'s' if n != 1 else ''} kept in {progress_path(out)}"
    if run.complete and n < MIN_MEASURED:  # nothing left to throw, too few to fit: resuming cannot help
        return f"{kept}: too few to fit a library ({MIN_MEASURED}); remove that file to train again"
    return (
        f"{kept}: run `wiithrow train` again with the same --out and --resume to go on, or remove that file to "
        "start again"
    )


def _throws(args: argparse.Namespace, session: Session) -> TrainingRun:
    """The run's throws, a progress bar over them on a terminal."""
    run = session.snapshot().training
    assert run is not None
    operator = OperatorInput.from_stdin()
    policy = args.on_lost or ("ask" if operator.is_terminal else "stop")
    bar = progress_bar(
        total=run.count, desc="training throws", unit="throw", show=not args.json, leave=False,
        initial=run.measured + run.skipped,
    )  # fmt: skip

    def say(line: str) -> None:
        bar.write(line, file=sys.stderr)

    def on_done(done: TrainingRun, i: int) -> None:
        bar.update(1)
        throw = done.throws[i]
        if args.json:
            return
        t = throw.target
        if throw.measured is not None:
            m = throw.measured
            say(
                f"  throw {i + 1:2d}/{done.count}: aimed at x {t[0]:.3f} z {t[1]:.3f} m, "
                f"landed (measured) x {m[0]:.3f} z {m[1]:.3f} m (link1)"
            )
        else:
            say(f"  throw {i + 1:2d}/{done.count}: aimed at x {t[0]:.3f} z {t[1]:.3f} m, skipped ({throw.note})")

    try:
        return throw_the_run(session, FailedThrows(policy, operator, say), operator=operator, say=say, on_done=on_done)
    finally:
        bar.close()


def _report(
    args: argparse.Namespace, outcome: TrainingOutcome, loo: LeaveOneOutResult, run: TrainingRun, kept: dict[str, Any]
) -> None:
    """The library written and its two held-out figures (module docstring), as text or JSON."""
    area = run.area
    if args.json:
        emit(
            {
                "library": outcome.path,
                "world": "hardware" if args.settings else sim_world_name(args),
                "arm": run.arm,
                "throws": outcome.throws,
                "skipped": outcome.skipped,
                "trained_area_throw_plane_link1": {"x_m": list(area.x), "z_m": list(area.z)},
                "regression_loo_mean_m": outcome.heldout_mean_m,
                "regression_loo_median_m": outcome.heldout_median_m,
                "regression_loo_max_m": outcome.heldout_max_m,
                "model_mismatch_mean_m": loo.mean,
                "model_mismatch_median_m": loo.median,
                "model_mismatch_max_m": loo.max,
                "loo_mean_m": loo.mean,  # the model mismatch, under its former name
                "loo_median_m": loo.median,
                "loo_max_m": loo.max,
                **kept,
            }
        )
        return
    skipped = f" ({outcome.skipped} of {run.count} skipped)" if outcome.skipped else ""
    print(
        f"wrote {outcome.path}: {outcome.throws} throws{skipped} of arm {run.arm} over x {area.x[0]:.2f}-"
        f"{area.x[1]:.2f} m, z {area.z[0]:.2f}-{area.z[1]:.2f} m (link1 throw plane)"
    )
    print(
        f"the regression's held-out error (leave-one-out: the throw predicted for each trained landing without it, "
        f"against the throw that made it, both flown by the model): mean {1e3 * outcome.heldout_mean_m:.1f} mm, "
        f"median {1e3 * outcome.heldout_median_m:.1f} mm, max {1e3 * outcome.heldout_max_m:.1f} mm; "
        "how well the library generalises to a target it was not trained on"
    )
    print(
        f"the model mismatch (the same predicted throws flown by the planner's model, against the measured "
        f"landings): mean {1e3 * loo.mean:.1f} mm, median {1e3 * loo.median:.1f} mm, max {1e3 * loo.max:.1f} mm; "
        "how far the model's flight is from the world's, which the learning absorbs (not the library's quality)"
    )
