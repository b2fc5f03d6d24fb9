"""`wiithrow serve`: the dashboard over real hardware (remotes found by hidapi, arm driver from
settings).

Builds an `wiithrow.app.worlds.hardware.HardwareWorld` (the first `rig.count` Wiimotes hidapi finds, the arm
from the settings' `arm_driver`, "module:factory") and serves it exactly as `wiithrow demo` serves
the simulated one. The rig has --cameras remotes, or as many as the calibration has cameras (when
no settings file says otherwise), placed as the settings say; a wand calibration in the first
camera's frame is placed on link1 by that remote's nominal pose (`wiithrow.app.worlds.base.on_link1`). Without an arm driver the arm is parked (`robot.ParkedArm`, at its home pose):
the dashboard shows each remote's dots and, with `--calibration`, the tracked markers in the
scene; the buttons that would move the arm are disabled and say why. Throwing stays simulated:
the ball's release and the landing's measurement have no real driver in this version. With
--publish the rig's tracked markers, each camera's dots and the throws go out over Zenoh while it
runs (`wiithrow.app.cli.publishing`; docs/integrations/zenoh.md). With --markers-from PREFIX
no remote is read here: the markers are those another host tracks and publishes under PREFIX
(`wiithrow.app.worlds.remote`), and the arm, the session and the dashboard run on them; they are
checked before they are adopted (`wiithrow.app.network.marker_checks`: signed with this user's
secret, from the Zenoh id given with --markers-source, else from the publisher the operator
confirms in the dashboard's Marker source folder, `wiithrow.web.source_panel`), the source's
notices are shown as the session's message, and at the end the frames refused are printed by reason.
Settings that name an arm driver with no passing `wiithrow check-driver` report (beside the settings
or in the cache: `wiithrow.app.drivercheck.store`) are served with a warning at start.
The throw library is the library folder's version in use (`--library-folder`, else the settings'
`library_folder`, else `<arm>-library` beside the calibration, else beside the settings:
`wiithrow.app.session.library_folder`; its path is printed at start), else the shipped one;
`--library FILE` is kept as a version of the folder and put in use. The learning's updates and the
Training panel's libraries are new versions of it; the dashboard's Library folder lists them.
`--record FILE.mcap` records the session (remotes' raw reports, markers, arm, throws) as it runs
(refused with --markers-from: no remote is read here; record with `track --publish --record` on
the host that has them). Each driver the settings name ("module:factory": code the settings file
runs, docs/bring-up/settings.md, "Settings files run code") is printed on stderr, its spec and the file its module
came from, before its factory runs.
"""

from __future__ import annotations

import argparse
import sys
from typing import TYPE_CHECKING

from wiithrow.app.calibration.robot import DEFAULT_POSES
from wiithrow.app.cli.arguments import (
    add_learn_argument,
    camera_count,
    dashboard_poses,
    output_file,
    port,
    positive_float,
)
from wiithrow.app.cli.foxglove_flags import add_foxglove_arguments, check_foxglove_arguments, foxglove_session
from wiithrow.app.cli.library_flags import add_library_arguments, store_from_args
from wiithrow.app.cli.publishing import (
    MarkersFrom,
    add_publish_arguments,
    check_markers_from_arguments,
    publish_session,
)
from wiithrow.app.cli.ros2_flags import add_ros2_arguments, check_ros2_arguments, ros2_session
from wiithrow.app.cli.serving import (
    access_from_args,
    add_access_arguments,
    add_scene_argument,
    add_train_to_argument,
    check_port_free,
    run_dashboard,
    train_to_from_args,
)
from wiithrow.app.errors import AppError

if TYPE_CHECKING:
    from wiithrow.app.worlds.hardware import LoadedDriver

NAME = "serve"
HELP = "the dashboard on real hardware (remotes by hidapi, arm driver from settings)"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--host", default="127.0.0.1", help="address to bind (default: 127.0.0.1, this machine only)")
    parser.add_argument("--port", type=port, default=8080, help="port (default: 8080; 0: any free port)")
    add_access_arguments(parser)
    add_scene_argument(parser)
    parser.add_argument("--settings", help="settings JSON (the arm, its driver and the rig)")
    parser.add_argument(
        "--calibration", help="calibration JSON to track with from the start (from `wiithrow calibrate`)"
    )
    parser.add_argument(
        "--cameras",
        type=camera_count,
        help="remotes in the rig, 2 to 4 (default: the calibration's, else the settings' rig.count)",
    )
    parser.add_argument(
        "--poses",
        type=dashboard_poses,
        default=DEFAULT_POSES,
        help=f"calibration poses of the Calibrate button (default: {DEFAULT_POSES})",
    )
    add_library_arguments(parser)
    add_train_to_argument(parser)
    add_learn_argument(parser)
    parser.add_argument(
        "--duration", type=positive_float, default=None, help="stop after this many seconds (default: run until Ctrl-C)"
    )
    add_publish_arguments(parser, markers_from=True)
    add_ros2_arguments(parser)
    add_foxglove_arguments(parser)
    parser.add_argument(
        "--record", metavar="FILE.mcap", help="record the session to this MCAP file (replay: `wiithrow replay`)"
    )


def run(args: argparse.Namespace, *, drivers=None) -> int:
    """`drivers`: the remotes' drivers instead of hidapi's (tests). Missing or inaccessible remotes
    are an AppError saying what to do (`wiithrow.app.rig.hardware.hardware_drivers`)."""
    import numpy as np

    from wiithrow.app.session import Session
    from wiithrow.app.session.library_folder import starting_library
    from wiithrow.app.settings import Settings
    from wiithrow.app.worlds.hardware import HardwareWorld
    from wiithrow.clock import SystemClock
    from wiithrow.vision import StereoCalibration

    access = access_from_args(args)
    check_port_free(args.host, args.port)
    check_markers_from_arguments(args)
    check_ros2_arguments(args)
    check_foxglove_arguments(args)
    markers_from = getattr(args, "markers_from", None)
    if markers_from is not None and getattr(args, "record", None):
        raise AppError(
            "--record does not apply with --markers-from: no remote is read here; record where the remotes are "
            "(`wiithrow track --publish --record FILE.mcap` on that host)"
        )
    record = output_file(args, "record")
    settings = Settings.load(args.settings) if args.settings else Settings()
    from wiithrow.app.cli.world_choice import hardware_world_line

    print(hardware_world_line(settings, args.settings), file=sys.stderr, flush=True)
    calibration = StereoCalibration.load(args.calibration) if args.calibration else None
    count = getattr(args, "cameras", None) or (
        len(calibration.cameras) if calibration is not None and not args.settings else None
    )
    if count is not None:
        settings = settings.with_cameras(count)
    if calibration is not None:  # made on this arm? (a link1 is one arm's)
        from wiithrow.app.worlds.base import check_calibration_fits, unknown_arm_warning

        check_calibration_fits(calibration, remotes=settings.rig.count, arm=settings.arm, source=args.calibration)
        warning = unknown_arm_warning(calibration, settings.arm, args.calibration)
        if warning is not None:
            print(f"wiithrow serve: warning: {warning}", file=sys.stderr, flush=True)
    if args.settings and settings.arm_driver:  # a throw on this arm: has its driver been checked?
        from wiithrow.app.drivercheck.store import driver_report_status

        status = driver_report_status(settings, args.settings)
        if status is not None:
            print(f"wiithrow serve: warning: {status}", file=sys.stderr, flush=True)
    clock = SystemClock()
    remote = MarkersFrom(args, NAME, settings, clock) if markers_from is not None else None
    try:
        if remote is not None:  # the remotes are on the host that publishes: none is read here
            world = HardwareWorld(settings, source=remote.rig, clock=clock, on_load=_print_loaded)
        else:
            world = HardwareWorld(
                settings, calibration=calibration, drivers=drivers, clock=clock, on_load=_print_loaded
            )
    except BaseException:
        if remote is not None:
            remote.close()
        raise
    try:  # the library folder once the world stands (a settings file that fails makes none)
        store = store_from_args(
            args,
            NAME,
            arm=settings.arm,
            settings_folder=settings.library_folder,
            settings_path=args.settings,
            calibration_path=args.calibration,
        )
        given, version = starting_library(
            store, args.library, settings.arm, lambda line: print(f"wiithrow serve: {line}", file=sys.stderr)
        )
        print(f"wiithrow serve: library folder {store.folder}", file=sys.stderr, flush=True)
    except BaseException:
        world.close()
        if remote is not None:
            remote.close()
        raise
    if not world.arm_connected:
        print(
            "wiithrow serve: no arm driver in the settings (arm_driver): the arm is taken to be parked at its "
            "home pose and does not move; the dashboard tracks markers only",
            file=sys.stderr,
            flush=True,
        )
    if calibration is None and remote is None:
        print(
            "wiithrow serve: no --calibration: the dashboard shows each remote's dots; markers are tracked "
            "once the rig is calibrated",
            file=sys.stderr,
            flush=True,
        )
    session = Session(
        world, library=given, rng=np.random.default_rng(0), learn=not args.no_learn, store=store, version=version
    )
    train_to_from_args(args, session)
    if remote is not None:
        remote.tell(session)  # whom the markers follow and what was refused, on the dashboard
    publishing = publish_session(args, NAME, session)
    ros2 = ros2_session(args, NAME, session)
    foxglove = foxglove_session(args, NAME, session)
    try:
        return run_dashboard(
            session,
            host=args.host,
            port=args.port,
            access=access,
            default_poses=args.poses,
            duration=args.duration,
            record=record,
            plain_scene=args.plain_scene,
        )
    finally:
        if foxglove is not None:
            foxglove.close()
        if ros2 is not None:
            ros2.close()
        if publishing is not None:
            publishing.close()
        if remote is not None:
            remote.close()


def _print_loaded(driver: LoadedDriver) -> None:
    """One line per driver the settings name, before it runs: a settings file runs code."""
    print(f"wiithrow serve: loaded {driver}", file=sys.stderr, flush=True)
