"""Calibrate a stereo rig from a CSV of known 3D points, then triangulate new pixels.

The CSV has one row per known point: x, y, z (metres, in the frame you want the calibration in),
then u, v (pixels) for each camera, NaN where a camera did not see the point. Here we make one
with two simulated Wiimotes so that the example runs anywhere; with your own rig, measure the
points (a robot's forward kinematics, a surveyed grid) and write the same columns.

    python examples/01_calibrate_and_triangulate.py [points.csv]
"""

import sys
import tempfile
from pathlib import Path

import numpy as np

from wiithrow.app.calibration.point_files import read_calibration_points, write_calibration_points
from wiithrow.app.calibration.points import calibrate_rig
from wiithrow.vision.rig import observe_all, points_in_common_view, stereo_rig

rng = np.random.default_rng(0)
cameras = stereo_rig()  # two Wiimotes 0.25 m apart, f = 1300 px (the default rig)

if len(sys.argv) > 1:
    csv = Path(sys.argv[1])
else:
    points = points_in_common_view(cameras, 30, rng)  # (30, 3) m
    csv = Path(tempfile.mkdtemp()) / "points.csv"
    write_calibration_points(csv, points, observe_all(cameras, points, rng))  # 0.5 px noise, integer pixels

world, image = read_calibration_points(csv)  # (N, 3) metres and (C, N, 2) pixels
fit = calibrate_rig(world, image, method="refined", frame="link1")
for camera in fit.calibration.cameras:
    print(f"{camera.name}: {camera.world.shape[0]} points, reprojection RMS {camera.rms_px:.2f} px")
print(f"leave-one-out 3D error: {1e3 * fit.loo.mean:.2f} mm")

# Triangulate pixels the rig has not seen before: 5 new points in the same volume.
truth = points_in_common_view(cameras, 5, rng)
pixels = observe_all(cameras, truth, rng)  # what the remotes would report
found = fit.calibration.triangulate(pixels).points  # (5, 3) m
for p, t in zip(found, truth):
    print(f"triangulated {np.round(p, 4)} m, true {np.round(t, 4)} m, error {1e3 * np.linalg.norm(p - t):.2f} mm")
