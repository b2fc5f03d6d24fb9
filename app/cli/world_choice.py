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
  prints on stderr, "world: MuJoCo (simulated)" or "world: hardware (settings S.json: arm pa10, ...)",
  and for drivers of `MUJOCO_DRIVERS` (the MuJoCo rehearsal) "world: hardware path on MuJoCo's simulated
  arm, gripper and remotes, not real devices (settings S.json: ...)";
* `hardware_world(args, command)`: the settings loaded, the driver check's warning (a throw on an
  arm whose driver has no passing `wiithrow check-driver` report, `wiithrow.app.drivercheck.store`),
  each driver named before it runs, the `HardwareWorld`;
* `landing_prompt` / `operator_measures_landing(world, what, ...)`: on hardware nobody but the
  operator knows where the ball came down: the command asks them (a prompt on stderr, a line on
  stdin: Enter) to put the IR marker where it first touched down, cover the target and press Enter,
  and the rig measures it (`wiithrow.app.throws.execution.measure_marker`). The prompt comes once the
  ball is down: the arm at rest, then `LANDING_SETTLE_S` more; what was typed or piped before it is
  discarded (`operator_input.OperatorInput`), so only a line written after the prompt measures: an
  Enter piped ahead cannot race the touchdown. A marker the rig does not see is asked for again, up
  to `LANDING_LOOKS` looks; then, or at the end of input, `LandingNotMeasured`. The MuJoCo drivers'
  simulated operator puts the marker down at the touchdown; a test (or a script) presses Enter by
  writing a line once it has read the prompt.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Callable
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from wiithrow.app.cli.operator_input import OperatorInput
from wiithrow.app.errors import NO_MARKER_SEEN, AppError, LandingNotMeasured

if TYPE_CHECKING:
    from wiithrow.app.settings import Settings
    from wiithrow.app.worlds.base import RigWorld
    from wiithrow.app.worlds.hardware import HardwareWorld
    from wiithrow.vision import StereoCalibration

#: The simulated world of every `--sim` command unless `--world` says otherwise: one world by
#: default everywhere, the demo's.
DEFAULT_WORLD = "mujoco"

#: How each simulated world is named in a command's first line: its class's `title`, which the
#: dashboard shows (not imported here, to keep MuJoCo out of a command's start; a test checks they agree).
WORLD_NAMES = {"mujoco": "MuJoCo (simulated)", "kinematic": "kinematic (simulated: the planner's own models)"}

#: The module of the MuJoCo world's devices as drivers (`wiithrow.app.worlds.mujoco.drivers`: the
#: rehearsal's settings, examples/mujoco_settings.json), which the world line names as simulated.
MUJOCO_DRIVERS = "wiithrow.app.worlds.mujoco.drivers"

#: How long (s) the rig is read between looks at whether the operator pressed Enter.
READ_WHILE_WAITING_S = 0.05

#: How long (s, the world's clock) the landing prompt waits after the throw's arm came to rest:
#: the shipped arms' throws fly 0.37-0.56 s (the simulated operator's throws at their areas'
#: corners) and the arm rests 0.11-0.23 s after the release, so the prompt comes at least 1.1 s after
#: the release, twice the longest flight: the ball is down (a lab's much longer throw needs more).
LANDING_SETTLE_S = 1.0
#: How many times the rig looks for the operator's landing marker (each after a prompt's Enter)
#: before the landing counts as not seen.
LANDING_LOOKS = 3
#: What the operator is asked to do at the terminal.
PUT_MARKER = "put the IR marker where the ball first touched down, cover the target, then press Enter"


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
    simulated = [
        device
        for device, driver in (
            ("arm", settings.arm_driver),
            ("gripper", settings.gripper_driver),
            ("remotes", settings.remotes_driver),
        )
        if driver and driver.partition(":")[0] == MUJOCO_DRIVERS
    ]
    if simulated:
        devices = ", ".join(simulated[:-1]) + (" and " if len(simulated) > 1 else "") + simulated[-1]
        return f"world: hardware path on MuJoCo's simulated {devices}, not real devices ({where}: arm {settings.arm}, {drivers})"
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
            "write one (docs/bring-up/index.md) and check it with `wiithrow check-driver`"
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


def landing_prompt(
    world: RigWorld,
    what: str,
    operator: OperatorInput,
    *,
    say: Callable[[str], None],
    keep_reading: bool = True,
    settle_s: float = LANDING_SETTLE_S,
    choices: str = "",
    again: str = "",
) -> str | None:
    """Once the ball is down, ask the operator to mark where `what` (e.g. "throw 3/25") came down,
    and return their line (stripped; "" for Enter), None at the end of input. The arm is at rest
    when this is called; the prompt waits `settle_s` more on the world's clock (the rig read
    meanwhile, and while the operator walks over, when `keep_reading`; False when something else
    reads it, a running session's loop: remotes left unread for seconds overflow their reports'
    buffers, and the first measurement after that sees no marker), then discards what was typed or piped before it
    (`OperatorInput.discard_pending`), then asks (`choices`: what else the line may say, e.g.
    "r retries the throw"). `again`: why the last look measured nothing ("the rig does not see a
    marker"): said first, and no settle time."""
    from wiithrow.app.rig.waiting import pump

    if settle_s > 0 and not again:
        if keep_reading:
            pump(world.clock, world.rig, settle_s, step_s=0.01)
        else:
            world.clock.sleep(settle_s)
    operator.discard_pending()
    head = f"{what}: {again}: " if again else f"{what}: "
    tail = f" ({choices})" if choices else ""
    say(f"{head}{PUT_MARKER}{tail}")

    def step() -> None:
        pump(world.clock, world.rig, READ_WHILE_WAITING_S, step_s=0.01)

    line = operator.wait_line(step if keep_reading else None)
    return None if line is None else line.strip()


def operator_measures_landing(
    world: RigWorld,
    what: str,
    *,
    measure: Callable[[], NDArray[np.float64]] | None = None,
    operator: OperatorInput | None = None,
    say: Callable[[str], None] | None = None,
    keep_reading: bool = True,
    settle_s: float = LANDING_SETTLE_S,
) -> NDArray[np.float64]:
    """Ask the operator to mark where `what` (e.g. "the throw") came down, then measure it: the
    marker in link1 (3,). The prompt comes once the ball is down and takes only a line written after
    it (`landing_prompt`). `measure` (default `measure_marker(world)`) returns NaN, or raises
    `LandingNotMeasured`, when the rig sees no marker (the session's *Measure landing* does; its
    words are the dashboard's, so the terminal says its own); `operator` is stdin
    (`OperatorInput.from_stdin()` by default), `say` prints (default: a line on stderr; a progress
    bar's `write`). `LandingNotMeasured` at the end of input, or after `LANDING_LOOKS` looks that saw
    no marker (`wiithrow throw`: the throw stays in the session's history, unmeasured)."""
    from wiithrow.app.throws.execution import measure_marker

    def default() -> NDArray[np.float64]:
        return measure_marker(world)

    measure = measure or default
    operator = operator or OperatorInput.from_stdin()

    def stderr(line: str) -> None:
        print(line, file=sys.stderr, flush=True)

    say = say or stderr
    again = ""
    for _ in range(LANDING_LOOKS):
        line = landing_prompt(world, what, operator, say=say, keep_reading=keep_reading, settle_s=settle_s, again=again)
        if line is None:
            raise LandingNotMeasured(f"{what}: no operator at the terminal to mark the landing (end of input)")
        again = NO_MARKER_SEEN
        try:
            point = np.asarray(measure(), dtype=float)
        except LandingNotMeasured as exc:
            again = exc.reason
            continue
        if np.isfinite(point).all():
            return point
    raise LandingNotMeasured(
        f"{what}: the rig saw no landing marker in {LANDING_LOOKS} looks: put it in both remotes' view"
    )
