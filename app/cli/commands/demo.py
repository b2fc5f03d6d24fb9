"""`wiithrow demo`: the whole simulated system with the operator's dashboard (what `make demo` runs).

Starts the simulated world in real time (two simulated Wiimotes speaking HID bytes, the simulated
PA-10, the ball), the session's 100 Hz rig loop and the dashboard on http://127.0.0.1:8080 (prints
the address; `--host`/`--port` change it, and a host other than this machine's loopback prints a
warning: whoever reaches the port can move the robot). Then it places the simulated IR target
inside the throw library's trained area and starts the robot-driven calibration in the background
(its progress bar shows in the dashboard), so that the system is ready to track and throw. Runs
until Ctrl-C (or `--duration` seconds), then stops the arm and closes.
"""

from __future__ import annotations

import argparse
import sys
import time

import numpy as np

NAME = "demo"
HELP = "run the simulated system with the operator's dashboard (what `make demo` runs)"

#: Where the demo puts the simulated target: (distance, height) in the throw plane (inside the
#: trained area x 1.0-1.6 m, z 0-0.4 m) and its azimuth from the arm's x axis (rad), in the
#: rig's view at the home pose, so that "Track target" has something to do.
DEMO_TARGET_XZ = (1.3, 0.2)
DEMO_TARGET_AZIMUTH = 0.2


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--host", default="127.0.0.1", help="address to listen on (default: 127.0.0.1, this machine only)"
    )
    parser.add_argument("--port", type=int, default=8080, help="port (default: 8080)")
    parser.add_argument("--seed", type=int, default=0, help="random seed (default: 0)")
    parser.add_argument(
        "--poses",
        type=int,
        default=30,
        help="calibration poses, for the automatic start and the Calibrate button (default: 30)",
    )
    parser.add_argument("--no-calibrate", action="store_true", help="do not start the calibration automatically")
    parser.add_argument("--library", default=None, help="throw library JSON (default: the shipped one)")
    parser.add_argument(
        "--duration", type=float, default=None, help="stop after this many seconds (default: run until Ctrl-C)"
    )


def demo_target_base(azimuth: float = DEMO_TARGET_AZIMUTH, xz: tuple[float, float] = DEMO_TARGET_XZ) -> np.ndarray:
    """The demo target in `base` (m): distance xz[0] from the joint-1 axis at `azimuth`, height xz[1]."""
    return np.array([xz[0] * np.cos(azimuth), xz[0] * np.sin(azimuth), xz[1]])


def make_session(*, seed: int = 0, library: str | None = None, realtime: bool = True, quiet: bool = False):
    """A session on a fresh simulated world (real time by default), with the throw library at
    `library`, or the shipped one; if none is shipped yet, a stand-in trained in simulation."""
    from wiithrow.app.session.session import Session
    from wiithrow.app.throws.library_file import default_library_path, load_library
    from wiithrow.app.worlds.simulated import SimWorld

    world = SimWorld(seed=seed, realtime=realtime)
    if library is None and not default_library_path().exists():
        from wiithrow.throwing import simulated_library

        if not quiet:
            print(
                "wiithrow demo: no trained throw library is installed (make one with `wiithrow train --sim`); "
                "using a stand-in trained on the simulated arm",
                file=sys.stderr,
            )
        lib = simulated_library(world.arm_model, seed)
    else:
        lib = load_library(library)
    return Session(world, library=lib, rng=np.random.default_rng(seed))


def run(args: argparse.Namespace) -> int:
    session = make_session(seed=args.seed, library=args.library)
    session.set_target(demo_target_base())
    poses = 0 if args.no_calibrate else args.poses
    return run_dashboard(
        session, host=args.host, port=args.port, default_poses=args.poses, calibrate_poses=poses, duration=args.duration
    )


def run_dashboard(
    session, *, host: str, port: int, default_poses: int = 30, calibrate_poses: int = 0, duration: float | None = None
) -> int:
    """Serve `session` with the dashboard until Ctrl-C (or `duration` s): print the address (and
    the warning for a host other than loopback), start a calibration of `calibrate_poses` poses if
    > 0; at the end stop the arm, let the running operation end, close everything."""
    from wiithrow.web.server import Dashboard, exposure_warning, is_local_host

    dashboard = Dashboard(session, host=host, port=port, default_poses=default_poses)
    try:
        dashboard.start()
        print(f"wiithrow dashboard: {dashboard.url}  (Ctrl-C to stop)", flush=True)
        if not is_local_host(host):
            print(exposure_warning(host, dashboard.port), file=sys.stderr, flush=True)
        if calibrate_poses > 0:
            dashboard.start_calibration(calibrate_poses)
        end = None if duration is None else time.monotonic() + duration
        while end is None or time.monotonic() < end:
            time.sleep(0.2)
    except KeyboardInterrupt:
        pass
    finally:
        session.stop()
        dashboard.runner.join(timeout=5.0)
        dashboard.close()
        session.close()
    return 0
