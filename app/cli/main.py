"""The `wiithrow` command line: one subcommand per module in `wiithrow.app.cli.commands`.

Each command module exposes `NAME`, `HELP`, `add_arguments(parser)` and `run(args) -> int`.
Expected failures (bad flags, an unknown flag or command with the closest known one:
`did_you_mean`, bad files, bad points, unreachable targets, busy devices, outputs
that cannot be written) are printed as one line on stderr, `wiithrow CMD: ...`, with exit status
2; anything else is a bug and keeps its traceback. While a command runs, warnings, log records
and the end of a thread are one line each too (`one_line_output`). A command given `--json` prints exactly one
strict JSON document on stdout and everything else on stderr (`json_output`). `main` returns
the exit status (also for argparse's own exits), so tests call it in-process.
"""

from __future__ import annotations

import argparse
import importlib
import os
import sys
from collections.abc import Sequence

from wiithrow.app.cli.arguments import Parser
from wiithrow.app.cli.did_you_mean import unknown_command_message
from wiithrow.app.cli.json_output import json_mode
from wiithrow.app.cli.one_line import one_line_output
from wiithrow.app.errors import expected_errors

# Order is the order of `wiithrow --help`; each command's name (its module's NAME) and its module.
COMMAND_MODULES = {
    "demo": "wiithrow.app.cli.commands.demo",
    "calibrate": "wiithrow.app.cli.commands.calibrate",
    "triangulate": "wiithrow.app.cli.commands.triangulate",
    "devices": "wiithrow.app.cli.commands.devices",
    "track": "wiithrow.app.cli.commands.track",
    "listen": "wiithrow.app.cli.commands.listen",
    "replay": "wiithrow.app.cli.commands.replay",
    "export": "wiithrow.app.cli.commands.export",
    "train": "wiithrow.app.cli.commands.train",
    "throw": "wiithrow.app.cli.commands.throw",
    "library": "wiithrow.app.cli.commands.library",
    "reproduce": "wiithrow.app.cli.commands.reproduce",
    "check-driver": "wiithrow.app.cli.commands.check_driver",
    "serve": "wiithrow.app.cli.commands.serve",
    "bench": "wiithrow.app.cli.commands.bench",
}


def _available_commands(names: Sequence[str]) -> list:
    modules = []
    for name in names:
        try:
            modules.append(importlib.import_module(COMMAND_MODULES[name]))
        except ModuleNotFoundError as exc:
            if exc.name != COMMAND_MODULES[name]:  # a command that exists but cannot import is a bug: say so
                raise
    return modules


def build_parser(command: str | None = None) -> argparse.ArgumentParser:
    """The command line's parser: every command's, or only `command`'s (a name of
    `COMMAND_MODULES`). `main` builds only the command it is given: each command's module imports
    what the command runs on (`wiithrow listen` a Zenoh session; `wiithrow demo` scipy, numba,
    pinocchio, viser), and importing all of them would take most of every command's start."""
    parser = Parser(
        prog="wiithrow",
        description="Two Wiimotes as a calibrated stereo IR camera, and a robot arm that throws a ball at what they see.",
    )
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", required=True)
    for module in _available_commands([command] if command in COMMAND_MODULES else list(COMMAND_MODULES)):
        command_parser = sub.add_parser(module.NAME, help=module.HELP, description=module.HELP)
        module.add_arguments(command_parser)
        command_parser.set_defaults(run=module.run)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    try:
        argv = list(sys.argv[1:] if argv is None else argv)
        if argv and not argv[0].startswith("-") and argv[0] not in COMMAND_MODULES:
            close = unknown_command_message(argv[0], COMMAND_MODULES)
            if close is not None:  # else argparse's line lists every command
                print(close, file=sys.stderr)
                return 2
        args = build_parser(argv[0] if argv else None).parse_args(argv)
    except SystemExit as exc:  # --help (0) or a bad flag (2, one line already printed)
        return exc.code if isinstance(exc.code, int) else 2
    try:
        with one_line_output(args.command):  # warnings, log records, threads' ends: one line each
            if getattr(args, "json", False):
                with json_mode():
                    return int(args.run(args) or 0)
            return int(args.run(args) or 0)
    except expected_errors() as exc:
        print(f"wiithrow {args.command}: {exc}", file=sys.stderr)
        return 2
    except MemoryError:  # an input too large for this machine (nothing is written before the work is done)
        print(
            f"wiithrow {args.command}: out of memory: the input is too large for this machine; nothing was written",
            file=sys.stderr,
        )
        return 2
    except KeyboardInterrupt:
        print(f"wiithrow {args.command}: interrupted", file=sys.stderr)
        return 130
    except BrokenPipeError:  # the reader went away (`wiithrow track | head`): stop quietly
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
        return 0


if __name__ == "__main__":
    sys.exit(main())
