"""`wiithrow triangulate`: 3D points from pixels with a saved calibration.

wiithrow triangulate --calibration calibration.json --points pixels.csv [--out points.csv] [--refine]

`--out` is checked before anything is read or computed, and written atomically.
"""

from __future__ import annotations

import argparse
import csv
import io
import sys

import numpy as np

from wiithrow.app.calibration.point_files import read_image_points
from wiithrow.app.cli.arguments import output_file
from wiithrow.vision import StereoCalibration
from wiithrow.vision.files import atomic_write_text

NAME = "triangulate"
HELP = "triangulate pixels (u, v per camera per row) into 3D points with a calibration"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--calibration", required=True, help="a calibration JSON written by `wiithrow calibrate`")
    parser.add_argument(
        "--points", required=True, metavar="FILE.csv", help="rows of u, v per camera (NaN where unseen)"
    )
    parser.add_argument("--out", help="CSV to write (default: standard output)")
    parser.add_argument("--refine", action="store_true", help="Gauss-Newton refinement on the reprojection error")


def run(args: argparse.Namespace) -> int:
    out_path = output_file(args, "out")
    calibration = StereoCalibration.load(args.calibration)
    image = read_image_points(args.points, len(calibration.cameras))
    result = calibration.triangulate(image, refine=args.refine)
    out = io.StringIO()
    writer = csv.writer(out, lineterminator="\n")
    writer.writerow(["x", "y", "z", "reprojection_px", "views"])
    for X, err, n in zip(result.points, result.reprojection_error_px, result.n_views):
        writer.writerow([f"{v:.6f}" for v in X] + [f"{err:.3f}", int(n)])
    if out_path is not None:
        atomic_write_text(out_path, out.getvalue())
        seen = int(np.isfinite(result.points).all(axis=1).sum())
        print(f"wrote {len(result.points)} points ({seen} triangulated) in frame {calibration.frame} to {out_path}")
    else:
        sys.stdout.write(out.getvalue())
    return 0
