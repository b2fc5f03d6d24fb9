"""`wiithrow check-driver`: exercise the arm (and hand) drivers a settings file names, before they
throw, and report pass or fail per check against stated bounds.

    wiithrow check-driver --settings S.json [--calibration cal.json] [--yes] [--json] [--out report.json]

The drivers are built exactly as `wiithrow serve` builds them (`arm_driver`, `gripper_driver`, on
the system clock), and moved only through the Arm and Gripper interfaces: small slow motions
first, a Stop, commands beyond the limits, then a throw planned from the arm's model (no throw
library needed: any arm with a throwing section in its spec) slowed down, and the throw's joints
at the speed of its fastest throws, the hand empty (`wiithrow.app.drivercheck.procedure`); the
hand is held to the close and open times the settings state (`hand_close_s`, `hand_open_s`). With `--calibration` (the rig's, as `serve` takes it) the
settings' remotes (`remotes_driver`, else the Wiimotes found) track the hand's LED, and the rig
checks that the arm moves as its state says (check "seen moving"; without a calibration that
check is not run, and the report does not pass). The arm moves: the operator confirms (a terminal's prompt,
or `--yes`). The report (`wiithrow.app.drivercheck.report`) is printed as a table (or, with
`--json`, as the one JSON document on stdout) and written atomically beside the settings
(`S.driver-report.json`, or `--out`) and to the cache (`wiithrow.app.drivercheck.store`), where
`wiithrow serve` looks before it starts. Exit status 0 when every check passed, 1 otherwise.
"""

from __future__ import annotations

import argparse
import datetime
import sys

from wiithrow.app.cli.json_output import emit
from wiithrow.app.errors import AppError

NAME = "check-driver"
HELP = (
    "check the arm and hand drivers of a settings file before they throw (state, following, Stop, limits, "
    "the rig seeing the arm move, a throw slowed down, throwing speed, the hand's release)"
)


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--settings", required=True, help="settings JSON naming arm_driver (and gripper_driver)")
    parser.add_argument("--yes", action="store_true", help="move the arm without asking for confirmation")
    parser.add_argument("--json", action="store_true", help="print the report as one JSON document")
    parser.add_argument("--out", help="where to write the report (default: beside the settings, S.driver-report.json)")
    parser.add_argument(
        "--calibration",
        help="the rig's calibration JSON (from `wiithrow calibrate`): the rig watches the hand's LED move "
        "as the arm's state says (without it that check is not run)",
    )


def run(args: argparse.Namespace) -> int:
    from wiithrow.app.drivercheck.hand_probe import HandTimes
    from wiithrow.app.drivercheck.procedure import run_checks
    from wiithrow.app.drivercheck.report import DriverReport
    from wiithrow.app.drivercheck.rig_probe import RigWatch, rig_watch
    from wiithrow.app.drivercheck.store import cached_report_path, report_path_for, save_report
    from wiithrow.app.settings import Settings
    from wiithrow.app.worlds.hardware import HardwareWorld, load_arm_driver, load_driver
    from wiithrow.clock import SystemClock
    from wiithrow.robot.gripper import Gripper
    from wiithrow.throwing import Ball
    from wiithrow.vision import StereoCalibration
    from wiithrow.vision.outputs import check_output_file

    settings = Settings.load(args.settings)
    if not settings.arm_driver:
        raise AppError(f"{args.settings} names no arm_driver: there is no driver to check")
    out = check_output_file(args.out or report_path_for(args.settings))
    calibration = StereoCalibration.load(args.calibration) if args.calibration else None
    if not args.yes and not _confirm(settings.arm_driver):
        print("wiithrow check-driver: not checked; the arm did not move", file=sys.stderr)
        return 1
    clock = SystemClock()
    world: HardwareWorld | None = None
    watch: RigWatch | None = None
    if calibration is not None:  # the drivers and the remotes, as serve builds them
        world = HardwareWorld(settings, calibration=calibration, clock=clock)
        model, arm, gripper = world.arm_model, world.arm, world.gripper
        world.connect()
        watch = rig_watch(world)
        if not callable(getattr(arm, "set_marker_led", None)):
            print("wiithrow check-driver: the arm's driver cannot switch the hand's LED: light it", file=sys.stderr)
    else:
        model = settings.load_arm()
        arm = load_arm_driver(settings.arm_driver, model, clock, settings)
        gripper = None
        if settings.gripper_driver:
            gripper = load_driver(settings.gripper_driver, "gripper_driver", model, clock, settings)
            if not isinstance(gripper, Gripper):
                raise AppError(
                    f"gripper_driver {settings.gripper_driver!r} returned a {type(gripper).__name__}, which does "
                    "not implement wiithrow.robot.gripper.Gripper (open, close, state)"
                )
    b = settings.ball  # the ball the throws are planned for (nothing is thrown)
    try:
        checks = run_checks(
            arm,
            model,
            clock,
            gripper=gripper,
            ball=Ball(
                radius=b.radius_m, mass=b.mass_kg, drag_coefficient=b.drag_coefficient, air_density=b.air_density
            ),
            hand_times=HandTimes(settings.hand_close_s, settings.hand_open_s),
            say=lambda message: print(f"wiithrow check-driver: {message}", file=sys.stderr, flush=True),
            watch=watch,
        )
    finally:
        if world is not None:
            world.close()
    report = DriverReport(
        settings.arm,
        settings.arm_driver,
        settings.gripper_driver,
        "system",
        checks,
        created_utc=datetime.datetime.now(datetime.UTC).isoformat(timespec="seconds"),
        settings_file=str(args.settings),
    )
    save_report(report, out)
    cached: str | None = None
    try:
        cached = str(save_report(report, cached_report_path(settings)))
    except OSError as exc:  # the report beside the settings is what counts; the cache is a convenience
        print(f"wiithrow check-driver: the cache keeps no copy ({exc})", file=sys.stderr)
    if args.json:
        emit({**report.to_dict(), "report_file": str(out), "cached_report_file": cached})
    else:
        print(report.table())
        print(f"wrote {out}")
    return 0 if report.passed else 1


def _confirm(driver: str) -> bool:
    if not sys.stdin.isatty():
        raise AppError("the check moves the arm and needs a confirmation: run it in a terminal, or pass --yes")
    return input(f"The check moves the arm of {driver}: is its workspace clear? [y/N] ").strip().lower() in ("y", "yes")
