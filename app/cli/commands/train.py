"""`wiithrow train`: make the trained-throw library (25 throws labelled by the rig).

    wiithrow train --sim [--out library.json] [--calibration cal.json] [--seed 0]

The shipped library of the simulated PA-10 (throwing/data/pa10_sim_library.json) is made with
`wiithrow train --sim --out throwing/data/pa10_sim_library.json`.
"""

from __future__ import annotations

import argparse
import json
import sys

import numpy as np

from wiithrow.app.errors import AppError
from wiithrow.app.session import simulated_session
from wiithrow.app.session.simulated import WORLDS
from wiithrow.app.throws.library_file import save_library
from wiithrow.app.throws.training import train_in_world
from wiithrow.throwing import TRAINING_AREA, leave_one_out_error

NAME = "train"
HELP = "train the throw library: 25 throws, each labelled with its landing as the rig measures it"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--sim", action="store_true", help="train on the simulated arm and rig")
    parser.add_argument("--out", default="library.json", help="where to write the library (default: library.json)")
    parser.add_argument("--calibration", help="calibration JSON to measure with (default in simulation: calibrate now)")
    parser.add_argument(
        "--world",
        choices=WORLDS,
        default="kinematic",
        help="the simulated world: mujoco (physics the planner does not know) or kinematic (its own models) (default: kinematic)",
    )
    parser.add_argument("--seed", type=int, default=0, help="random seed of the simulation (default: 0)")
    parser.add_argument("--json", action="store_true", help="print the result as JSON")


def run(args: argparse.Namespace) -> int:
    if not args.sim:
        raise AppError(
            "training on a real arm needs an arm driver, and this installation has none: use --sim "
            "(the procedure is the same: play each throw, put a marker where it landed, measure it)"
        )
    session = simulated_session(
        world=args.world, seed=args.seed, calibration=args.calibration or "robot", quiet=args.json
    )
    world = session.world
    done = []

    def on_throw(target, measured):
        done.append(1)
        if not args.json:
            print(
                f"  throw {len(done):2d}/25: aimed at x {target[0]:.3f} z {target[1]:.3f} m, "
                f"landed (measured) x {measured[0]:.3f} z {measured[1]:.3f} m",
                file=sys.stderr,
            )

    library = train_in_world(
        world,
        np.random.default_rng(args.seed),
        on_throw=on_throw,
        meta={"seed": args.seed, "calibration": args.calibration or "robot, simulated"},
    )
    path = save_library(args.out, library)
    loo = leave_one_out_error(library)
    area = {"x_m": list(TRAINING_AREA.x), "z_m": list(TRAINING_AREA.z)}
    if args.json:
        print(
            json.dumps(
                {
                    "library": str(path),
                    "throws": len(library.throws),
                    "trained_area": area,
                    "loo_mean_m": loo.mean,
                    "loo_median_m": loo.median,
                    "loo_max_m": loo.max,
                },
                indent=2,
            )
        )
    else:
        print(
            f"wrote {path}: {len(library.throws)} throws over x {TRAINING_AREA.x[0]}-{TRAINING_AREA.x[1]} m, "
            f"z {TRAINING_AREA.z[0]}-{TRAINING_AREA.z[1]} m (link1 throw plane)"
        )
        print(loo)
    return 0
