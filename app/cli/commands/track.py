"""`wiithrow track`: stream tracked 3D markers (id, time, x, y, z, frame) as JSON lines or CSV.

    wiithrow track --sim [--cameras N] [--duration 5] [--speed 2.0] [--format csv] [--out markers.csv]
    wiithrow track --calibration calibration.json [--duration 10]          (real remotes)

Without real remotes (or with --sim) the simulated rig looks at four markers on crossing paths and
runs faster than real time unless --realtime is given. The simulated rig has --cameras remotes
(2 to 4, placed by the settings: `Settings.with_cameras`), or as many as the calibration has
cameras, or two; it tracks with the calibration given (a robot's or a wand's, in its own frame)
or with the true cameras. Real remotes: as many as the calibration has cameras.
"""

from __future__ import annotations

import argparse
import csv
import json
import sys
from typing import IO

import numpy as np

from wiithrow.app.errors import AppError
from wiithrow.app.rig.stream import RigStream
from wiithrow.clock import SimClock, SystemClock
from wiithrow.vision import StereoCalibration
from wiithrow.vision.tracker import TrackedFrame

NAME = "track"
HELP = "stream tracked 3D markers as JSON lines or CSV (simulated rig when no remote is found)"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--sim", action="store_true", help="use the simulated rig (the default when no remote is found)"
    )
    parser.add_argument(
        "--calibration", help="calibration JSON (required with real remotes; default in simulation: the true cameras)"
    )
    parser.add_argument("--duration", type=float, default=5.0, help="seconds to track (default: 5)")
    parser.add_argument("--format", choices=("jsonl", "csv"), default="jsonl", help="output format (default: jsonl)")
    parser.add_argument("--out", help="file to write (default: standard output)")
    parser.add_argument("--speed", type=float, default=2.0, help="simulation: peak marker speed in m/s (default: 2)")
    parser.add_argument("--realtime", action="store_true", help="simulation: pace it to the wall clock")
    parser.add_argument("--seed", type=int, default=0, help="simulation: random seed (default: 0)")
    parser.add_argument(
        "--cameras", type=int, help="simulation: remotes in the rig, 2 to 4 (default: the calibration's, or 2)"
    )


def run(args: argparse.Namespace) -> int:
    if args.duration <= 0:
        raise AppError(f"--duration must be positive, got {args.duration}")
    calibration = StereoCalibration.load(args.calibration) if args.calibration else None
    simulate = args.sim or not _remotes_present()
    if simulate:
        if not args.sim:
            print("wiithrow track: no Wiimote found, tracking the simulated rig (--sim)", file=sys.stderr)
        rig, clock, frame_name = _simulated(args, calibration)
    else:
        if calibration is None:
            raise AppError("real remotes need a calibration: --calibration FILE (from `wiithrow calibrate`)")
        if args.cameras is not None:
            raise AppError(
                "--cameras applies to the simulated rig (--sim); real remotes: as many as the calibration has"
            )
        from wiithrow.app.rig.hardware import hardware_drivers

        clock = SystemClock()
        rig = RigStream(hardware_drivers(len(calibration.cameras), clock), calibration.Ps)
        frame_name = calibration.frame
    out = open(args.out, "w", encoding="utf-8", newline="") if args.out else sys.stdout  # noqa: SIM115 (closed below)
    try:
        writer = _writer(out, args.format, frame_name)
        rig.connect()
        end = clock.now() + args.duration
        while clock.now() < end:
            for frame in rig.poll(timeout_s=0.0):
                writer(frame)
            clock.sleep(0.001)
    finally:
        rig.close()
        if out is not sys.stdout:
            out.close()
    return 0


def _remotes_present() -> bool:
    try:
        from wiithrow.vision.wiimote.transport import find_wiimotes

        return bool(find_wiimotes())
    except Exception:  # no hidapi backend at all: nothing to find
        return False


def _simulated(args: argparse.Namespace, calibration: StereoCalibration | None):
    from wiithrow.app.rig.moving_markers import crossing_paths
    from wiithrow.app.rig.simulated import simulated_drivers
    from wiithrow.app.settings import Settings
    from wiithrow.app.worlds import nominal_cameras

    count = args.cameras or (len(calibration.cameras) if calibration is not None else 2)
    if calibration is not None and len(calibration.cameras) != count:
        raise AppError(f"the calibration has {len(calibration.cameras)} cameras, --cameras {count}")
    cameras = nominal_cameras(Settings().with_cameras(count).rig)
    clock = SystemClock() if args.realtime else SimClock()
    drivers, _ = simulated_drivers(
        cameras,
        lambda t: crossing_paths(t, args.speed),
        clock,
        np.random.default_rng(args.seed),
        realtime=args.realtime,
    )
    Ps = calibration.Ps if calibration is not None else np.stack([c.P for c in cameras])
    return RigStream(drivers, Ps), clock, calibration.frame if calibration is not None else cameras[0].frame


def _writer(out: IO[str], fmt: str, frame_name: str):
    if fmt == "csv":
        rows = csv.writer(out, lineterminator="\n")
        rows.writerow(["id", "t", "x", "y", "z", "frame", "visible", "views"])

        def write(frame: TrackedFrame) -> None:
            for i, p, vis, n in zip(frame.ids, frame.position, frame.visible, frame.n_views):
                rows.writerow(
                    [
                        int(i),
                        f"{frame.t:.4f}",
                        f"{p[0]:.5f}",
                        f"{p[1]:.5f}",
                        f"{p[2]:.5f}",
                        frame_name,
                        int(vis),
                        int(n),
                    ]
                )
    else:

        def write(frame: TrackedFrame) -> None:
            for i, p, vis, n in zip(frame.ids, frame.position, frame.visible, frame.n_views):
                out.write(
                    json.dumps(
                        {
                            "id": int(i),
                            "t": round(frame.t, 4),
                            "x": round(float(p[0]), 5),
                            "y": round(float(p[1]), 5),
                            "z": round(float(p[2]), 5),
                            "frame": frame_name,
                            "visible": bool(vis),
                            "views": int(n),
                        }
                    )
                    + "\n"
                )

    return write
