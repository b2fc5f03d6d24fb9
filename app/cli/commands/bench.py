"""`wiithrow bench NAME [--json] [--quick]`: run a benchmark and print its figures."""

from __future__ import annotations

import argparse
import importlib

from wiithrow.app.cli.arguments import non_negative_float
from wiithrow.app.cli.bench import BENCHMARKS
from wiithrow.app.cli.json_output import emit
from wiithrow.app.errors import AppError
from wiithrow.app.worlds.named import WORLDS

#: The MuJoCo world's settings `bench throwing` takes from the command line.
WORLD_FLAGS = {
    "release_latency_ms": "the hand's latency (ms, default 10)",
    "release_jitter_ms": "the hand's jitter, a standard deviation (ms, default 3)",
    "placement_sigma_mm": "the landing marker's placement error, per axis (mm, default 5)",
    "kinematic_error_mm": "link-length tolerance (mm, default 1; joint zero offsets 2 mrad per mm)",
}

NAME = "bench"
HELP = "measure speed: " + ", ".join(BENCHMARKS)


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("name", choices=sorted(BENCHMARKS), help="which benchmark")
    parser.add_argument("--json", action="store_true", help="print the figures as JSON")
    parser.add_argument("--quick", action="store_true", help="smaller sizes, for a smoke test")
    parser.add_argument("--minutes", type=float, default=None, help="soak only: how long to run (default: 30)")
    parser.add_argument(
        "--seconds", type=float, default=None, help="ros2 and latency only: how long to run (default: 60)"
    )
    attached = parser.add_argument_group("the publishers `bench tracking` attaches, as `track` does")
    attached.add_argument(
        "--ros2", action="store_true", help="the ROS 2 publisher (loopback domain, put after each report)"
    )
    attached.add_argument("--foxglove", action="store_true", help="Foxglove live (a free loopback port)")
    world = parser.add_argument_group("the world of `bench throwing`")
    world.add_argument(
        "--world",
        choices=WORLDS,
        default=None,
        help="mujoco (default) or kinematic; `bench learning`: kinematic by default",
    )
    world.add_argument(
        "--settings",
        metavar="S.json",
        default=None,
        help="the hardware path: the drivers these settings name (examples/mujoco_settings.json), rig-measured landings",
    )
    world.add_argument(
        "--sim-clock",
        action="store_true",
        help="with --settings: the drivers on a simulated clock (simulated drivers only; figures without the host's lateness)",
    )
    for flag, what in WORLD_FLAGS.items():
        world.add_argument(f"--{flag.replace('_', '-')}", type=non_negative_float, default=None, help=what)


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
    if args.seconds is not None:
        if args.name not in ("ros2", "latency"):
            raise AppError("--seconds is for `wiithrow bench ros2` and `wiithrow bench latency` only")
        if not args.seconds > 0:
            raise AppError(f"--seconds must be > 0, got {args.seconds:g}")
        options["seconds"] = args.seconds
    for flag in ("ros2", "foxglove"):
        if getattr(args, flag, False):
            if args.name != "tracking":
                raise AppError(f"--{flag} is for `wiithrow bench tracking` only")
            options[flag] = True
    world = {k: getattr(args, k) for k in WORLD_FLAGS if getattr(args, k, None) is not None}
    if getattr(args, "world", None) is not None:
        world["world"] = args.world
    if getattr(args, "settings", None) is not None:
        world["settings_file"] = args.settings
    if getattr(args, "sim_clock", False):
        if args.name != "throwing" or "settings_file" not in world:
            raise AppError("--sim-clock is for `wiithrow bench throwing --settings S.json` only")
        options["sim_clock"] = True
    allowed = (args.name == "learning" and set(world) == {"world"}) or (
        args.name == "following" and set(world) == {"settings_file"}
    )
    if world and args.name != "throwing" and not allowed:
        raise AppError(
            f"--world and the world's settings are options of `bench throwing` (--world also of `bench learning`, "
            f"--settings of `bench following`), not of {args.name!r}"
        )
    figures = module.run(quick=args.quick, **options, **world)
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
