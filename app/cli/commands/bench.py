"""`wiithrow bench NAME [--json] [--quick]`: run a benchmark and print its figures."""

from __future__ import annotations

import argparse
import importlib

from wiithrow.app.cli.bench import BENCHMARKS
from wiithrow.app.cli.json_output import emit
from wiithrow.app.errors import AppError

NAME = "bench"
HELP = "measure speed: " + ", ".join(BENCHMARKS)


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("name", choices=sorted(BENCHMARKS), help="which benchmark")
    parser.add_argument("--json", action="store_true", help="print the figures as JSON")
    parser.add_argument("--quick", action="store_true", help="smaller sizes, for a smoke test")
    parser.add_argument("--minutes", type=float, default=None, help="soak only: how long to run (default: 30)")


def run(args: argparse.Namespace) -> int:
    try:
        module = importlib.import_module(BENCHMARKS[args.name])
    except ModuleNotFoundError as exc:
        if exc.name == BENCHMARKS[args.name]:
            raise AppError(f"benchmark {args.name!r} is not available in this version") from None
        raise
    options = {}
    if args.minutes is not None:
        if args.name != "soak":
            raise AppError("--minutes is for `wiithrow bench soak` only")
        if not args.minutes > 0:
            raise AppError(f"--minutes must be > 0, got {args.minutes:g}")
        options["minutes"] = args.minutes
    figures = module.run(quick=args.quick, **options)
    if args.json:
        emit(figures)
    else:
        _print(figures)
    return 0


def _print(figures: dict, indent: str = "") -> None:
    for key, value in figures.items():
        if isinstance(value, dict):
            print(f"{indent}{key}:")
            _print(value, indent + "  ")
        elif isinstance(value, float):
            print(f"{indent}{key}: {value:,.4g}")
        else:
            print(f"{indent}{key}: {value}")
