"""Where a command that moves the arm runs: a simulated world (`--sim [--world mujoco|kinematic]`)
or the hardware path (`--settings S.json`: the arm, hand and remotes drivers the settings name,
loaded into `wiithrow.app.worlds.hardware.HardwareWorld` exactly as `wiithrow serve --settings`
loads them).

Owns the choice and what is said about it:

* `add_world_arguments(parser)`: `--sim`, `--world` (default `DEFAULT_WORLD`, MuJoCo: physics the
  planner does not know, the world `wiithrow demo` runs) and `--settings`;
* `require_world_choice(args, command)`: neither `--sim` nor `--settings` is one line saying what to
  pass; both is one line too;
* `sim_world_line(name)` / `hardware_world_line(settings, path)`: the first line every command
  prints on stderr, "world: MuJoCo (simulated)" or "world: hardware (settings S.json: arm pa10, ...)";
* `hardware_world(args, command)`: the settings loaded, the driver check's warning (a throw on an
  arm whose driver has no passing `wiithrow check-driver` report, `wiithrow.app.drivercheck.store`),
  each driver named before it runs, the `HardwareWorld`;
* `operator_measures_landing(world, what, ...)`: on hardware nobody but the operator knows where the
  ball came down: the command asks them (a prompt on stderr, a line on stdin: Enter) to put the IR
  marker where it first touched down, and the rig measures it (`wiithrow.app.throws.execution.
  measure_marker`); a marker the rig does not see is asked for again, an end of input is an
  AppError. The MuJoCo drivers' simulated operator puts the marker down at the touchdown; a test
  (or a script) presses Enter by writing a line.
"""

from __future__ import annotations

import argparse
import sys
import threading
from collections.abc import Callable
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from wiithrow.app.errors import AppError

if TYPE_CHECKING:
    from wiithrow.app.settings import Settings
    from wiithrow.app.worlds.base import RigWorld
    from wiithrow.app.worlds.hardware import HardwareWorld
    from wiithrow.vision import StereoCalibration

#: The simulated world of every `--sim` command unless `--world` says otherwise (issue 21: one world
#: by default everywhere, the demo's).
DEFAULT_WORLD = "mujoco"

#: How each simulated world is named in a command's first line: its class's `title`, which the
#: dashboard shows (not imported here, to keep MuJoCo out of a command's start; a test checks they agree).
WORLD_NAMES = {"mujoco": "MuJoCo (simulated)", "kinematic": "kinematic (simulated: the planner's own models)"}

#: How long (s) the rig is read between looks at whether the operator pressed Enter.
READ_WHILE_WAITING_S = 0.05

#: How many times a landing marker the rig does not see is asked for before giving up.
MARKER_ATTEMPTS = 5


def add_world_arguments(parser: argparse.ArgumentParser, *, what: str) -> None:
    """`--sim`, `--world` and `--settings` for a command that `what`s (e.g. "trains")."""
    from wiithrow.app.worlds.named import WORLDS

    parser.add_argument("--sim", action="store_true", help=f"{what} in a simulated world (see --world)")
    parser.add_argument(
        "--world",
        choices=WORLDS,
        default=None,
        help="with --sim: mujoco (physics the planner does not know, the demo's world) or kinematic (the planner's "
        f"own models, fast) (default: {DEFAULT_WORLD})",
    )
    parser.add_argument(
        "--settings",
        metavar="S.json",
        help=f"{what} on the hardware path: the arm, hand and remotes drivers these settings name (as `wiithrow "
        "serve --settings`; examples/mujoco_settings.json is the MuJoCo rehearsal)",
    )


def require_world_choice(args: argparse.Namespace, command: str) -> None:
    """AppError (one line) unless exactly one of --sim and --settings was given; --world only with --sim."""
    sim, settings = bool(getattr(args, "sim", False)), getattr(args, "settings", None)
    if sim and settings:
        raise AppError("--sim and --settings are two worlds: give one (--settings runs the drivers it names)")
    if not sim and not settings:
        raise AppError(
            f"say where to {command}: --settings S.json (the arm, hand and remotes drivers it names; "
            "examples/mujoco_settings.json rehearses in MuJoCo) or --sim [--world mujoco|kinematic]"
        )
    if settings and getattr(args, "world", None):
        raise AppError("--world does not apply with --settings (the settings name the drivers): it is for --sim")


def sim_world_name(args: argparse.Namespace) -> str:
    """The simulated world `--world` names, `DEFAULT_WORLD` when not given."""
    return getattr(args, "world", None) or DEFAULT_WORLD


def sim_world_line(name: str) -> str:
    """A command's first line in simulated world `name`."""
    return f"world: {WORLD_NAMES.get(name, name)}"


def hardware_world_line(settings: Settings, path: str | None) -> str:
    """A command's first line on the hardware path: the settings file (None: the defaults), the arm
    and its drivers."""
    drivers = ", ".join(
        f"{key} {value}"
        for key, value in (
            ("arm_driver", settings.arm_driver),
            ("gripper_driver", settings.gripper_driver),
            ("remotes_driver", settings.remotes_driver or "hidapi's Wiimotes"),
        )
        if value
    )
    if not settings.arm_driver:
        drivers = f"{drivers}, no arm_driver: the arm is parked"
    where = f"settings {path}" if path else "no settings file"
    return f"world: hardware ({where}: arm {settings.arm}, {drivers})"


def check_calibration_file(
    calibration: StereoCalibration, path: str, *, arm: str, remotes: int, command: str
) -> StereoCalibration:
    """`calibration`, read from `path`, for a command that moves arm `arm` through a rig of
    `remotes` remotes: checked to fit (one camera per remote, link1, made on this arm: AppError
    naming both arms), with a warning line on stderr when it does not say which arm it was made on
    (`unknown_arm_warning`)."""
    from wiithrow.app.worlds.base import check_calibration_fits, unknown_arm_warning

    check_calibration_fits(calibration, remotes=remotes, frame="link1", arm=arm, source=path)
    warning = unknown_arm_warning(calibration, arm, path)
    if warning is not None:
        print(f"wiithrow {command}: warning: {warning}", file=sys.stderr, flush=True)
    return calibration


def say_world(line: str) -> None:
    print(line, file=sys.stderr, flush=True)


def hardware_world(
    args: argparse.Namespace,
    command: str,
    *,
    calibration: StereoCalibration | None = None,
    needs_arm: bool = True,
    warn_unchecked: bool = False,
) -> HardwareWorld:
    """The `HardwareWorld` of `--settings` (module docstring): the first line, the driver check's
    warning when `warn_unchecked`, each driver named on stderr before its factory runs. AppError
    when `needs_arm` and the settings name no arm driver."""
    from wiithrow.app.settings import Settings
    from wiithrow.app.worlds.hardware import HardwareWorld

    settings = Settings.load(args.settings)
    say_world(hardware_world_line(settings, args.settings))
    if needs_arm and not settings.arm_driver:
        raise AppError(
            f"{command} moves the arm, and the settings {args.settings} name no arm_driver ('module:factory'): "
            "write one (README, 'From unboxing to a trained throw') and check it with `wiithrow check-driver`"
        )
    if warn_unchecked:
        from wiithrow.app.drivercheck.store import driver_report_status

        status = driver_report_status(settings, args.settings)
        if status is not None:
            print(f"wiithrow {command}: warning: {status}", file=sys.stderr, flush=True)
    return HardwareWorld(
        settings,
        calibration=calibration,
        on_load=lambda driver: print(f"wiithrow {command}: loaded {driver}", file=sys.stderr, flush=True),
    )


def operator_measures_landing(
    world: RigWorld,
    what: str,
    *,
    measure: Callable[[], NDArray[np.float64]] | None = None,
    read_line: Callable[[], str] | None = None,
    say: Callable[[str], None] | None = None,
    keep_reading: bool = True,
) -> NDArray[np.float64]:
    """Ask the operator to mark where `what` (e.g. "throw 3/25") came down, then measure it: the
    marker in link1 (3,). `measure` (default `measure_marker(world)`) may raise AppError when the
    rig does not see a marker (the session's *Measure landing*); `read_line` reads the Enter
    (default: a line of stdin), `say` prints (default: a line on stderr; a progress bar's `write`).
    While the operator walks over, the rig is read (`keep_reading`; False when something else
    reads it, a running session's loop): remotes left unread for seconds overflow their reports'
    buffers, and the first measurement after that saw no marker. AppError at the end of input or
    after `MARKER_ATTEMPTS` tries."""
    from wiithrow.app.throws.execution import measure_marker

    def default() -> NDArray[np.float64]:
        return measure_marker(world)

    measure = measure or default
    read_line = read_line or sys.stdin.readline

    def stderr(line: str) -> None:
        print(line, file=sys.stderr, flush=True)

    say = say or stderr
    prompt = f"{what}: put the IR marker where the ball first touched down (cover the target), then press Enter"
    for _ in range(MARKER_ATTEMPTS):
        say(prompt)
        if not _wait_for_line(world, read_line, keep_reading):
            raise AppError(f"{what}: no operator at the terminal to mark the landing (end of input)")
        try:
            point = np.asarray(measure(), dtype=float)
        except AppError as exc:
            say(f"  {exc}")
            continue
        if np.isfinite(point).all():
            return point
        say("  the rig does not see a marker: put it in the remotes' view")
    raise AppError(f"{what}: the rig saw no landing marker in {MARKER_ATTEMPTS} tries")


def _wait_for_line(world: RigWorld, read_line: Callable[[], str], keep_reading: bool) -> str:
    """The operator's line (empty at the end of input), the rig read meanwhile when `keep_reading`."""
    if not keep_reading:
        return read_line()
    from wiithrow.app.rig.waiting import pump

    line: list[str] = []
    reader = threading.Thread(target=lambda: line.append(read_line()), name="operator-enter", daemon=True)
    reader.start()
    while reader.is_alive():
        pump(world.clock, world.rig, READ_WHILE_WAITING_S, step_s=0.01)
    return line[0] if line else ""
