"""`wiithrow export`: a recording as a ROS 2 bag.

    wiithrow export run.mcap run.ros2.mcap [--ros2-namespace /wiithrow]

Writes the recording's channels that have a ROS 2 form (the markers, each camera's dots, /tf,
/tf_static, the arm's joints and trajectories, the throws, the robot description) as an MCAP file
of the `ros2` profile, `ros2msg` schemas and CDR messages, under the topics `--ros2` publishes
(`wiithrow.app.recording.ros2_bag`; docs/integrations/recording.md: why a second file): what
`ros2 bag info`, `ros2 bag play`, rosbags and `mcap-ros2-support` read. The output is written
whole or not at all; a recording cut short is exported as far as it is intact (said on stderr); a
recording from a newer wiithrow, or one whose message does not fit its channel, is one line, exit 2.
"""

from __future__ import annotations

import argparse
import sys

from wiithrow.app.cli.arguments import output_file

NAME = "export"
HELP = "write a recording (MCAP) as a ROS 2 bag: ros2 profile, ros2msg schemas, CDR"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("recording", metavar="FILE.mcap", help="a recording (`--record`)")
    parser.add_argument("out", metavar="OUT.mcap", help="the ROS 2 bag to write (replaced if it exists)")
    parser.add_argument(
        "--ros2-namespace", metavar="NS", default=None, help="namespace of the topics (default: /wiithrow, as --ros2)"
    )


def run(args: argparse.Namespace) -> int:
    from wiithrow.app.channels.ros2_sink import DEFAULT_NAMESPACE
    from wiithrow.app.recording import read_recording
    from wiithrow.app.recording.ros2_bag import write_ros2_bag
    from wiithrow.app.ros2.domain import ros_namespace

    namespace = DEFAULT_NAMESPACE if args.ros2_namespace is None else ros_namespace(args.ros2_namespace)
    out = output_file(args, "out")
    assert out is not None
    recording = read_recording(args.recording)
    counts, end = write_ros2_bag(recording, out, namespace=namespace)
    if end is not None:
        print(f"wiithrow export: {end}; exported what came before", file=sys.stderr)
    topics = ", ".join(f"{topic} {count}" for topic, count in sorted(counts.items())) or "none"
    print(f"wiithrow export: {sum(counts.values())} messages to {out} (ros2 profile): {topics}", file=sys.stderr)
    return 0
