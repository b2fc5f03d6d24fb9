"""`wiithrow demo`: the whole simulated system with the operator's dashboard (what `make demo` runs).

Starts the simulated world in real time (two simulated Wiimotes speaking HID bytes, or --cameras
of them, the simulated PA-10, the ball), the session's 100 Hz rig loop and the dashboard on
http://127.0.0.1:8080 (prints the operator's link, with its token; `--host`/`--port` change the
address, and an address beyond this machine's loopback needs a token chosen for it,
`wiithrow.app.cli.serving`). Then it places the simulated IR target inside the throw library's
trained area and, once the first operator's page has connected (the terminal says it waits:
"waiting for an operator's page to calibrate"), starts the robot-driven calibration in the
background, so that the page shows its progress from the first pose and the system is then ready
to track and throw (`--no-calibrate`: never); with --calibration it tracks with
that one (a robot's or a wand's) instead. Runs until Ctrl-C (or `--duration` seconds), then stops
the arm and closes. With --publish the rig's tracked markers, each camera's dots and the throws
go out over Zenoh while it runs (`wiithrow.app.cli.publishing`; docs/integrations/zenoh.md).
`--record FILE.mcap` records the session (rig, arm, throws) as it runs. The throw library is the
world's library folder's version in use (`--library-folder`, else a folder of the simulated world's
own: `wiithrow.app.session.library_folder`; printed at start), else the shipped one; the learning's
updates and the Training panel's libraries are versions of it (the dashboard's Library folder).
"""

from __future__ import annotations

import argparse
import sys

from wiithrow.app.calibration.robot import DEFAULT_POSES
from wiithrow.app.cli.arguments import (
    add_learn_argument,
    add_world_argument,
    camera_count,
    dashboard_poses,
    output_file,
    port,
    positive_float,
    seed,
)
from wiithrow.app.cli.foxglove_flags import add_foxglove_arguments, check_foxglove_arguments, foxglove_session
from wiithrow.app.cli.library_flags import add_library_arguments, store_from_args
from wiithrow.app.cli.publishing import add_publish_arguments, check_publish_arguments, publish_session
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
from wiithrow.app.cli.world_choice import sim_world_line
from wiithrow.app.session import demo_target_base, simulated_session
from wiithrow.app.settings import Settings

NAME = "demo"
HELP = "run the simulated system with the operator's dashboard (what `make demo` runs)"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--host", default="127.0.0.1", help="address to listen on (default: 127.0.0.1, this machine only)"
    )
    parser.add_argument("--port", type=port, default=8080, help="port (default: 8080; 0: any free port)")
    add_access_arguments(parser)
    add_scene_argument(parser)
    add_world_argument(parser, "mujoco")
    parser.add_argument("--seed", type=seed, default=0, help="random seed (default: 0)")
    parser.add_argument(
        "--poses",
        type=dashboard_poses,
        default=DEFAULT_POSES,
        help=f"calibration poses, for the automatic start and the Calibrate button (default: {DEFAULT_POSES})",
    )
    parser.add_argument(
        "--no-calibrate",
        action="store_true",
        help="do not start the calibration automatically (by default it starts when an operator's page connects)",
    )
    parser.add_argument(
        "--calibration",
        help="track with this calibration (a robot's or a wand's) instead of calibrating with the robot at the start",
    )
    parser.add_argument(
        "--cameras",
        type=camera_count,
        help="simulated remotes, 2 to 4, placed by the settings (default: the calibration's, or 2)",
    )
    add_library_arguments(parser)
    add_train_to_argument(parser)
    add_learn_argument(parser)
    parser.add_argument(
        "--duration", type=positive_float, default=None, help="stop after this many seconds (default: run until Ctrl-C)"
    )
    add_publish_arguments(parser)
    add_ros2_arguments(parser)
    add_foxglove_arguments(parser)
    parser.add_argument(
        "--record", metavar="FILE.mcap", help="record the session to this MCAP file (replay: `wiithrow replay`)"
    )


def run(args: argparse.Namespace) -> int:
    access = access_from_args(args)
    check_port_free(args.host, args.port)
    check_publish_arguments(args)
    check_ros2_arguments(args)
    check_foxglove_arguments(args)
    record = output_file(args, "record")
    print(sim_world_line(args.world), file=sys.stderr, flush=True)
    store = store_from_args(args, NAME, arm=Settings().arm, world=args.world)
    print(f"wiithrow demo: library folder {store.folder}", file=sys.stderr, flush=True)
    session = simulated_session(
        world=args.world,
        seed=args.seed,
        calibration=args.calibration,
        library=args.library,
        store=store,
        say=lambda line: print(f"wiithrow demo: {line}", file=sys.stderr, flush=True),
        realtime=True,
        learn=not args.no_learn,
        cameras=args.cameras,
    )
    session.set_target(demo_target_base())
    train_to_from_args(args, session)
    poses = 0 if args.no_calibrate or args.calibration else args.poses
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
            calibrate_poses=poses,
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
