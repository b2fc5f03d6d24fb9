"""`wiithrow track`: stream tracked 3D markers as JSON lines or CSV.

    wiithrow track --sim [--cameras N] [--duration 5] [--speed 2.0] [--format csv] [--out markers.csv]
    wiithrow track --calibration calibration.json [--duration 10]          (real remotes)
    wiithrow track --sim --record run.mcap                                   (and record it: `wiithrow replay`)

Each row: `id`, `t` (s since tracking started), `x`, `y`, `z` (m) in `frame` (the calibration's
frame, link1 for the rig on the arm and for the simulated rig), `visible` (seen in this frame, not
predicted) and `views` (cameras that saw it). The first lines on stderr name the world and how long
it tracks (`--duration`). Without real remotes (or with --sim) the simulated
rig looks at four markers on crossing paths and runs faster than real time unless --realtime is
given; --speed, --realtime and --seed are refused with real remotes. `--out` is checked before
tracking starts and written to a temporary file renamed into place at the end; Ctrl-C ends the
tracking early, keeps the rows tracked so far and exits with status 130. A disk that fills up (or
any other failed write) ends it too: `--out` keeps every complete line written until then
(`wiithrow.vision.outputs.StagedFile`), standard output has had every row until the failing one
(it is flushed after each frame), and one line says so, exit status 2.
The simulated rig has --cameras remotes (2 to 4, placed by the settings:
`Settings.with_cameras`), or as many as the calibration has cameras, or two; it tracks with the
calibration given (a robot's or a wand's, in its own frame) or with the true cameras. Real
remotes: as many as the calibration has cameras.
With --publish each tracked frame (and each camera's dots) is also put on Zenoh under
`wiithrow/<--rig-name>/` as it comes out (`wiithrow.app.cli.publishing`;
docs/integrations/zenoh.md); with --ros2 as ROS 2 topics over DDS (`wiithrow.app.cli.ros2_flags`; docs/integrations/ros2.md); with
--foxglove [PORT] the recording's channels are served live to Foxglove (`wiithrow.app.cli.foxglove_flags`).
What was published is summed up on stderr at the end.
remotes: as many as the calibration has cameras. `--record FILE.mcap` records the run (the raw
reports, dots, markers, calibration, frames: `wiithrow.app.recording`), written as it goes.
"""

from __future__ import annotations

import argparse
import csv
import sys
from collections.abc import Callable
from typing import IO

import numpy as np

from wiithrow.app.cli.arguments import camera_count, output_file, positive_float, refuse_flags, seed
from wiithrow.app.cli.foxglove_flags import add_foxglove_arguments, check_foxglove_arguments, foxglove_rig
from wiithrow.app.cli.publishing import Publishing, add_publish_arguments, check_publish_arguments
from wiithrow.app.cli.ros2_flags import Ros2Publishing, add_ros2_arguments, check_ros2_arguments
from wiithrow.app.cli.row_output import Rows, StdoutRows
from wiithrow.app.errors import AppError
from wiithrow.app.rig.source import newest_t
from wiithrow.app.rig.stream import RigStream
from wiithrow.clock import Clock, SimClock, SystemClock
from wiithrow.vision import StereoCalibration
from wiithrow.vision.files import dumps_strict
from wiithrow.vision.outputs import StagedFile
from wiithrow.vision.tracked_frame import TrackedFrame

NAME = "track"
HELP = "stream tracked 3D markers as JSON lines or CSV (simulated rig when no remote is found)"

COLUMNS = ["id", "t", "x", "y", "z", "frame", "visible", "views"]


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--sim", action="store_true", help="use the simulated rig (the default when no remote is found)"
    )
    parser.add_argument(
        "--calibration", help="calibration JSON (required with real remotes; default in simulation: the true cameras)"
    )
    parser.add_argument("--duration", type=positive_float, default=5.0, help="seconds to track (default: 5)")
    parser.add_argument("--format", choices=("jsonl", "csv"), default="jsonl", help="output format (default: jsonl)")
    parser.add_argument("--out", help="file to write (default: standard output)")
    parser.add_argument("--speed", type=positive_float, help="simulation: peak marker speed in m/s (default: 2)")
    parser.add_argument("--realtime", action="store_true", help="simulation: pace it to the wall clock")
    parser.add_argument("--seed", type=seed, help="simulation: random seed (default: 0)")
    parser.add_argument(
        "--record", metavar="FILE.mcap", help="record the run to this MCAP file (replay: `wiithrow replay`)"
    )
    parser.add_argument(
        "--cameras", type=camera_count, help="simulation: remotes in the rig, 2 to 4 (default: the calibration's, or 2)"
    )
    add_publish_arguments(parser, wait=True)
    add_ros2_arguments(parser)
    add_foxglove_arguments(parser)


def run(args: argparse.Namespace) -> int:
    out_path = output_file(args, "out")
    check_publish_arguments(args)
    check_ros2_arguments(args)
    check_foxglove_arguments(args)
    record_path = output_file(args, "record")
    simulate = args.sim or not _remotes_present()
    if not simulate:
        refuse_flags(
            args, ("speed", "realtime", "seed", "cameras"), "to real remotes (they are for the simulated rig, --sim)"
        )
    calibration = StereoCalibration.load(args.calibration) if args.calibration else None
    if simulate:
        if not args.sim:
            print("wiithrow track: no Wiimote found, tracking the simulated rig (--sim)", file=sys.stderr)
        rig, clock, frame_name = _simulated(args, calibration)
        # the run's first line names the world (bad input was said before it, in one line): track has
        # no arm and no ball, so neither simulated world is built; its remotes watch crossing markers
        print("world: simulated rig (simulated remotes watching crossing test markers; no arm)", file=sys.stderr)
    else:
        if calibration is None:
            raise AppError("real remotes need a calibration: --calibration FILE (from `wiithrow calibrate`)")
        from wiithrow.app.rig.hardware import hardware_drivers

        clock = SystemClock()
        rig = RigStream(hardware_drivers(len(calibration.cameras), clock), calibration.Ps)
        print("world: hardware (the Wiimotes hidapi finds)", file=sys.stderr)
        frame_name = calibration.frame
    print(
        f"wiithrow track: {duration_line(args.duration, simulate and not args.realtime)}", file=sys.stderr, flush=True
    )
    publishing = Publishing(args, NAME, rig.camera_names, frame_name, clock) if args.publish else None
    ros2 = Ros2Publishing(args, NAME, rig.camera_names, frame_name, clock) if args.ros2 else None
    foxglove = foxglove_rig(args, NAME, rig, frame_name)
    staged = StagedFile(out_path) if out_path is not None else None
    recorder = None
    if record_path is not None:
        from wiithrow.app.recording import Recorder

        recorder = Recorder(
            record_path, clock, frame_id=frame_name, calibration_text=calibration.to_text() if calibration else None
        )
        recorder.start(rig)
    try:
        rows = _stream(
            rig,
            clock,
            args,
            frame_name,
            staged.handle if staged else StdoutRows(),
            publishing,
            ros2,
            on_start=recorder.mark_start if recorder is not None else None,
        )
    except BaseException:
        if staged is not None:
            staged.discard()
        raise
    finally:
        if publishing is not None:
            publishing.close()
        if ros2 is not None:
            ros2.close()
        if foxglove is not None:
            foxglove.close()
        if recorder is not None:
            recorder.close()
    if staged is not None:
        staged.commit()
    if rows < 0:
        print(f"wiithrow track: interrupted; the {-rows - 1} rows tracked until then are kept", file=sys.stderr)
        return 130
    return 0


def _stream(
    rig: RigStream,
    clock: Clock,
    args: argparse.Namespace,
    frame_name: str,
    out: Rows,
    publishing: Publishing | None = None,
    ros2: Ros2Publishing | None = None,
    *,
    on_start: Callable[[float], object] | None = None,
) -> int:
    """Track for `args.duration` s, writing rows to `out` (and publishing each frame); the number
    of rows, or -(rows + 1) when Ctrl-C ended it early. Any other failure propagates (after the
    rig is closed)."""
    writer = _writer(out, args.format, frame_name)
    for sink in (publishing, ros2):
        if sink is not None:
            sink.follow(rig)  # each event packed on the rig's thread, during each poll
    count = 0
    try:
        rig.connect()
        start = clock.now()
        if on_start is not None:
            on_start(start)  # the recording's /rig/start: replay's rows count t from it too
        end = start + args.duration
        since = newest_t(rig)
        while clock.now() < end:
            rig.poll()
            for frame in rig.tracked_since(since):
                count += writer(frame, start)
                out.flush()
                since = frame.t
            clock.sleep(0.001)
    except KeyboardInterrupt:
        return -(count + 1)
    finally:
        rig.close()
    return count


def duration_line(duration_s: float, simulated_time: bool) -> str:
    """What the run's second line says of how long it tracks (`simulated_time`: the simulated rig's
    clock, faster than real time)."""
    clock = " of simulated time, faster than real time unless --realtime" if simulated_time else ""
    return f"tracking for {duration_s:g} s{clock} (--duration to change; Ctrl-C stops early)"


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
    speed = args.speed if args.speed is not None else 2.0
    drivers, _ = simulated_drivers(
        cameras,
        lambda t: crossing_paths(t, speed),
        clock,
        np.random.default_rng(args.seed or 0),
        realtime=args.realtime,
    )
    if calibration is None:
        return RigStream(drivers, np.stack([c.P for c in cameras])), clock, cameras[0].frame
    return RigStream(drivers, calibration.Ps), clock, calibration.frame


def _writer(out: Rows | IO[str], fmt: str, frame_name: str):
    """write(frame, start) -> rows written: one row per marker, t counted from `start`."""
    if fmt == "csv":
        rows = csv.writer(out, lineterminator="\n")
        rows.writerow(COLUMNS)

        def write(frame: TrackedFrame, start: float) -> int:
            for i, p, vis, n in zip(frame.ids, frame.position, frame.visible, frame.n_views):
                rows.writerow(
                    [int(i), f"{frame.t - start:.4f}", f"{p[0]:.5f}", f"{p[1]:.5f}", f"{p[2]:.5f}", frame_name]
                    + [int(vis), int(n)]
                )
            return len(frame.ids)

        return write

    def write_json(frame: TrackedFrame, start: float) -> int:
        for i, p, vis, n in zip(frame.ids, frame.position, frame.visible, frame.n_views):
            row = [int(i), round(frame.t - start, 4), *(round(float(v), 5) for v in p), frame_name, bool(vis), int(n)]
            out.write(dumps_strict(dict(zip(COLUMNS, row))) + "\n")
        return len(frame.ids)

    return write_json
