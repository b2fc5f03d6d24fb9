"""`wiithrow reproduce --out DIR [--quick] [--seed S]`: the paper's figures from the simulated system.

Runs `wiithrow.app.studies.reproduce.run_reproduction` (robot-driven calibration through the simulated remotes,
Figs. 4-6, the pose-spread study, joint-1 alignment) and writes PNG, CSV and `summary.md` to DIR.
Progress bars on a terminal (not with --no-progress, nor into a pipe); the first line names the world.

Its default world stays the kinematic one, where every other `--sim` command defaults to MuJoCo:
reproduce makes the paper's figures, which are about the calibration and stereo geometry (Figs.
4-6), and their published numbers (docs/how-it-works.md, docs/simulation.md) are the kinematic world's, whose only errors are
the ones the figures study (pixel noise, the arm's joint tracking); MuJoCo adds the arm's
manufacturing tolerances and servo dynamics, which the figures do not separate (`--world mujoco`
runs them there).
"""

from __future__ import annotations

import argparse
import sys
import time

from wiithrow.app.cli.arguments import seed
from wiithrow.app.cli.world_choice import sim_world_line
from wiithrow.app.worlds.named import WORLDS

NAME = "reproduce"
HELP = "reproduce the paper's figures on the simulated system (PNG, CSV and summary.md)"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--out", required=True, metavar="DIR", help="directory for the figures, CSV files and summary.md"
    )
    parser.add_argument("--quick", action="store_true", help="fewer poses, sizes and draws: under a minute (for tests)")
    parser.add_argument("--seed", type=seed, default=0, help="random seed (default: 0)")
    parser.add_argument("--no-progress", action="store_true", help="no progress bars")
    parser.add_argument(
        "--world",
        choices=WORLDS,
        default="kinematic",
        help="the simulated world of the calibration and alignment studies: kinematic (the planner's own models, "
        "default) or mujoco (a servo-driven arm with manufacturing tolerances); Fig. 6 runs in the kinematic one",
    )


def run(args: argparse.Namespace) -> int:
    from wiithrow.app.studies.reproduce import check_reproduction_folder, run_reproduction

    check_reproduction_folder(args.out)  # bad input is one line, before the world's
    print(f"{sim_world_line(args.world)}; Fig. 6 in the kinematic world", file=sys.stderr, flush=True)
    start = time.perf_counter()
    result = run_reproduction(
        args.out, quick=args.quick, seed=args.seed, show_progress=not args.no_progress, world=args.world
    )
    print(f"wrote {len(result.files)} files to {args.out} in {time.perf_counter() - start:.0f} s:")
    for path in result.files:
        print(f"  {path.name}")
    knee = result.fig4.knee("refined")
    print(
        f"Fig. 4: refined within 10 % of its {result.fig4.sizes[-1]}-point error from n = {knee}; "
        f"Fig. 6: mono off by {1e3 * abs(result.fig6.depth_error('mono')).max():.0f} mm at "
        f"{result.fig6.angle_deg.max():.0f} deg, stereo by at most {1e3 * abs(result.fig6.depth_error('stereo')).max():.2f} mm; "
        f"alignment: {result.alignment.status} in {result.alignment.duration_s:.1f} s"
    )
    return 0
