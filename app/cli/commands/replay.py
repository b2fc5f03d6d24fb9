"""`wiithrow replay`: a recorded run's raw reports through the tracking pipeline again.

    wiithrow replay run.mcap [--format csv] [--out markers.csv] [--speed 1.0] [--calibration other.json]

Reads a recording of `track --record` (or `demo`/`serve --record`), feeds each remote's recorded
HID reports, with their receive times, to real `WiimoteDriver`s and repeats the rig's recorded
steps: the synchroniser, correspondence and tracker run again (`wiithrow.app.recording.replay`).
With the recorded calibration the markers are the recorded ones exactly, ids included; with
`--calibration` the same reports are tracked with another one. Rows as `wiithrow track` writes
them (`t` counted from the recording's first message). `--speed X` paces the replay at X times
real time (default: as fast as it goes). A file cut short or damaged replays what is intact and
says where it ends; a file from a newer wiithrow is refused.
"""

from __future__ import annotations

import argparse
import sys
from typing import TYPE_CHECKING

from wiithrow.app.cli.arguments import output_file, positive_float
from wiithrow.app.cli.commands.track import _writer
from wiithrow.vision import StereoCalibration
from wiithrow.vision.outputs import StagedFile

if TYPE_CHECKING:
    from wiithrow.vision.tracker import TrackedFrame

NAME = "replay"
HELP = "replay a recorded run (MCAP) through the tracking pipeline: the same markers, or with another calibration"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("recording", metavar="FILE.mcap", help="a recording of `track`, `demo` or `serve` --record")
    parser.add_argument("--format", choices=("jsonl", "csv"), default="jsonl", help="output format (default: jsonl)")
    parser.add_argument("--out", help="file to write (default: standard output)")
    parser.add_argument("--speed", type=positive_float, help="pace at this multiple of real time (default: at once)")
    parser.add_argument("--calibration", help="track with this calibration JSON instead of the recorded one")


def run(args: argparse.Namespace) -> int:
    from wiithrow.app.recording import Replay, read_recording  # mcap: only when replaying

    out_path = output_file(args, "out")
    calibration = StereoCalibration.load(args.calibration) if args.calibration else None
    recording = read_recording(args.recording)
    replay = Replay(recording, calibration.Ps if calibration is not None else None)
    frame_name = calibration.frame if calibration is not None else recording.frame_id
    start = recording.messages[0][1] / 1e9 if recording.messages else 0.0
    staged = StagedFile(out_path) if out_path is not None else None
    try:
        write = _writer(staged.handle if staged else sys.stdout, args.format, frame_name)
        rows = [0]

        def on_frame(frame: TrackedFrame) -> None:
            rows[0] += write(frame, start)

        replay.run(on_frame, speed=args.speed)
    except BaseException:
        if staged is not None:
            staged.discard()
        raise
    if staged is not None:
        staged.commit()
    if replay.end is not None:
        print(f"wiithrow replay: {replay.end}; replayed what is intact ({rows[0]} rows)", file=sys.stderr)
    return 0
