"""`wiithrow demo`: the simulated system end to end (what `make demo` runs).

Until the dashboard exists this is the calibration study of `wiithrow calibrate --demo`.
"""

from __future__ import annotations

import argparse

NAME = "demo"
HELP = "run the simulated system (what `make demo` runs)"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--seed", type=int, default=0, help="random seed (default: 0)")


def run(args: argparse.Namespace) -> int:
    from app.commands import calibrate

    args.json = False
    return calibrate._demo(args)
