"""`wiithrow replay`: a recorded run's raw reports through the tracking pipeline again.

    wiithrow replay run.mcap [--format csv] [--out markers.csv] [--speed 1.0] [--calibration other.json]
    wiithrow replay run.mcap --dashboard [--host H] [--port P] [--duration S]

Reads a recording of `track --record` (or `demo`/`serve --record`), feeds each remote's recorded
HID reports, with their receive times, to real `WiimoteDriver`s and repeats the rig's recorded
steps: the synchroniser, correspondence and tracker run again (`wiithrow.app.recording.replay`).
With the recorded calibration the markers are the recorded ones exactly, ids included; with
`--calibration` the same reports are tracked with another one. Rows as `wiithrow track` writes
them, `t` included: counted from the tracking start the recording holds (`/rig/start`, written by
`track --record`; an older recording's from its first message). `--speed X` paces the replay at X times
real time (default: as fast as it goes). A file cut short or damaged replays what is intact and
says where it ends; a file from a newer wiithrow is refused, and so is a chunk that declares or
expands to more than `MAX_CHUNK_BYTES` (64 MiB) decompressed. The file is streamed, a chunk at a
time: the replay's memory does not grow with the recording.

`--dashboard` shows the replay in the operator's dashboard instead of writing rows: each camera's
recorded IR reports are sent to a live driver at their recorded pace (real time), over and over,
read from the file again each time (`wiithrow.app.recording.replayed_remote`), tracked with
`--calibration`, or the calibration attached to the recording, or its recorded projection
matrices; the arm is parked. The markers move
as recorded; the exact numbers are the rows' (the reports are read in batches of this run).

`--foxglove [PORT]` (without `--dashboard`) writes the rows as without it, at once, then plays the
recording to Foxglove with Foxglove's timeline (`wiithrow.app.foxglove.player`): the recorded
channels, from the start at `--speed` (default 1, real time); Foxglove's play, pause, seek and
speed move it, and the replay ends at the recording's end, with or without a client (a pause
holds it until play or Ctrl-C). `--foxglove-wait` starts paused, for Foxglove to press play, and
keeps serving after the end, to scrub on, until Ctrl-C. The player serves what the file holds
(the markers as they were tracked), so `--calibration` is refused with `--foxglove`. With
`--dashboard`, `--foxglove` serves the dashboard's session live (no timeline).
"""

from __future__ import annotations

import argparse
import sys
import tempfile
from pathlib import Path
from typing import TYPE_CHECKING

from wiithrow.app.cli.arguments import output_file, port, positive_float, refuse_flags
from wiithrow.app.cli.commands.track import _writer
from wiithrow.app.cli.foxglove_flags import (
    add_foxglove_arguments,
    announce_foxglove,
    check_foxglove_arguments,
    foxglove_host,
    foxglove_session,
)
from wiithrow.app.cli.serving import access_from_args, add_access_arguments, add_scene_argument, check_port_free
from wiithrow.vision import StereoCalibration
from wiithrow.vision.outputs import StagedFile

if TYPE_CHECKING:
    from wiithrow.app.foxglove.player import FoxglovePlayer
    from wiithrow.app.recording import Recording

NAME = "replay"
HELP = "replay a recorded run (MCAP) through the tracking pipeline: the same markers, or with another calibration"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("recording", metavar="FILE.mcap", help="a recording of `track`, `demo` or `serve` --record")
    parser.add_argument("--format", choices=("jsonl", "csv"), help="output format (default: jsonl)")
    parser.add_argument("--out", help="file to write (default: standard output)")
    parser.add_argument("--speed", type=positive_float, help="pace at this multiple of real time (default: at once)")
    parser.add_argument("--calibration", help="track with this calibration JSON instead of the recorded one")
    parser.add_argument("--dashboard", action="store_true", help="show the replay in the dashboard instead")
    parser.add_argument("--host", help="--dashboard: address to listen on (default: 127.0.0.1, this machine only)")
    parser.add_argument("--port", type=port, help="--dashboard: port (default: 8080; 0: any free port)")
    parser.add_argument("--duration", type=positive_float, help="--dashboard: stop after this many seconds")
    add_access_arguments(parser)
    add_scene_argument(parser)
    add_foxglove_arguments(parser)
    parser.add_argument(
        "--foxglove-wait",
        action="store_true",
        help="with --foxglove: start paused until Foxglove plays, and keep serving after the end until Ctrl-C",
    )


def run(args: argparse.Namespace) -> int:
    from wiithrow.app.recording import Replay, read_recording  # mcap: only when replaying

    check_foxglove_arguments(args)
    if args.foxglove is None:
        refuse_flags(args, ("foxglove_wait",), "without --foxglove")
    if args.dashboard:
        refuse_flags(args, ("out", "format", "speed"), "with --dashboard (it shows the replay in real time)")
        refuse_flags(args, ("foxglove_wait",), "with --dashboard (its Foxglove view is live: no timeline)")
        return _dashboard(args)
    refuse_flags(args, ("host", "port", "duration"), "without --dashboard")
    if args.foxglove is not None:
        refuse_flags(
            args,
            ("calibration",),
            "with --foxglove (Foxglove's player serves the markers the recording holds; replay without --foxglove "
            "to track them with another calibration)",
        )
    out_path = output_file(args, "out")
    calibration = StereoCalibration.load(args.calibration) if args.calibration else None
    recording = read_recording(args.recording)
    replay = Replay(recording, calibration.Ps if calibration is not None else None)
    frame_name = calibration.frame if calibration is not None else recording.frame_id
    staged = StagedFile(out_path) if out_path is not None else None
    rows = 0
    player = _foxglove_player(args, recording)  # before the rows: a port taken is refused first
    try:
        try:
            write = _writer(staged.handle if staged else sys.stdout, args.format or "jsonl", frame_name)
            speed = None if player is not None else args.speed  # --speed is the player's
            for frame in replay.frames(speed=speed):  # streamed from the file: nothing kept
                rows += write(frame, replay.start)
        except BaseException:
            if staged is not None:
                staged.discard()
            raise
        finally:
            replay.close()
        if staged is not None:
            staged.commit()
        if replay.end is not None:
            print(f"wiithrow replay: {replay.end}; replayed what is intact ({rows} rows)", file=sys.stderr)
        if player is not None:
            player.run()
    finally:
        if player is not None:
            player.close()
    return 0


def _foxglove_player(args: argparse.Namespace, recording: Recording) -> FoxglovePlayer | None:
    """With --foxglove: the recording's player on its port, announced (not playing yet); else None."""
    if args.foxglove is None:
        return None
    from wiithrow.app.errors import AppError
    from wiithrow.app.foxglove.player import MAX_SPEED, MIN_SPEED, FoxglovePlayer

    if args.speed is not None and not MIN_SPEED <= args.speed <= MAX_SPEED:
        raise AppError(f"--speed {args.speed:g} with --foxglove: the player plays at x{MIN_SPEED:g} to x{MAX_SPEED:g}")
    host = foxglove_host(args)
    player = FoxglovePlayer(
        recording,
        port=args.foxglove,
        host=host,
        insecure_network=bool(args.foxglove_insecure_network),
        speed=args.speed if args.speed is not None else 1.0,
        wait=bool(args.foxglove_wait),
    )
    announce_foxglove(NAME, player, host)
    start, end = player.timeline.start / 1e9, player.timeline.end / 1e9
    then = "waits for Foxglove to play" if player.wait else f"plays at x{player.speed:g} once the rows are written"
    print(
        f"wiithrow replay: Foxglove's timeline is the recording's, t = {start:.3f} to {end:.3f} s: it {then}; "
        "Foxglove's play, pause, seek and speed move it" + (" (Ctrl-C to stop)" if player.wait else ""),
        file=sys.stderr,
        flush=True,
    )
    return player


def _dashboard(args: argparse.Namespace) -> int:
    import numpy as np

    from wiithrow.app.cli.serving import run_dashboard
    from wiithrow.app.errors import AppError
    from wiithrow.app.recording import read_recording
    from wiithrow.app.recording.channels import CALIBRATION_ATTACHMENT
    from wiithrow.app.recording.replayed_remote import ReplayedRemote, ReplayStart, recorded_calibration
    from wiithrow.app.session import Session
    from wiithrow.app.settings import Settings
    from wiithrow.app.throws.library_file import load_library
    from wiithrow.app.worlds.hardware import HardwareWorld
    from wiithrow.clock import SystemClock
    from wiithrow.vision.wiimote.device import WiimoteDriver

    args.host = args.host or "127.0.0.1"
    access = access_from_args(args)
    check_port_free(args.host, args.port if args.port is not None else 8080)
    recording = read_recording(args.recording)
    calibration: StereoCalibration | None = None
    if args.calibration:
        calibration = StereoCalibration.load(args.calibration)
    elif CALIBRATION_ATTACHMENT in recording.attachments:  # the calibration file the run was given
        with tempfile.TemporaryDirectory(prefix="wiithrow-replay-") as folder:
            attached = Path(folder) / "calibration.json"
            attached.write_bytes(recording.attachments[CALIBRATION_ATTACHMENT])
            calibration = StereoCalibration.load(attached)
    else:
        calibration = recorded_calibration(recording)
    clock = SystemClock()
    start = ReplayStart.of(recording)  # a first pass: the reports' timeline (the remotes stream each lap)
    if not all(start.counts):
        raise AppError(f"{args.recording}: camera {start.counts.index(0)} has no IR reports to replay")
    drivers = [
        WiimoteDriver(ReplayedRemote(recording, c, clock, start), clock, name=f"replay{c}")
        for c in range(recording.cameras)
    ]
    world = HardwareWorld(Settings().with_cameras(recording.cameras), calibration=calibration, drivers=drivers)
    if start.end is not None:
        print(f"wiithrow replay: {start.end}; replaying what is intact", file=sys.stderr)
    session = Session(world, library=load_library(None), rng=np.random.default_rng(0))
    foxglove = foxglove_session(args, NAME, session)
    try:
        return run_dashboard(
            session,
            host=args.host,
            port=args.port if args.port is not None else 8080,
            access=access,
            duration=args.duration,
            plain_scene=args.plain_scene,
        )
    finally:
        if foxglove is not None:
            foxglove.close()
