"""Read a wiithrow calibration and use it with OpenCV's camera model.

Each calibrated camera is a 3x4 projection matrix P; its RQ decomposition gives the intrinsics K
and the pose (R, t) with P ~ K [R | t], which is OpenCV's model without lens distortion (the
Wiimote's IR camera has almost none at its 1024x768 resolution): cameraMatrix = K,
rvec = Rodrigues(R), tvec = t, distCoeffs = 0. OpenCV is optional here (`pip install -e '.[bench]'`).

    python examples/04_calibration_in_opencv_terms.py [calibration.json]
"""

import sys
import tempfile
from pathlib import Path

import numpy as np
from scipy.spatial.transform import Rotation

from wiithrow.app.calibration.points import calibrate_rig
from wiithrow.vision import StereoCalibration
from wiithrow.vision.rig import observe_all, points_in_common_view, stereo_rig

if len(sys.argv) > 1:
    calibration = StereoCalibration.load(sys.argv[1])
else:  # make one from a simulated rig (what `wiithrow calibrate` writes)
    rng = np.random.default_rng(0)
    cameras = stereo_rig()
    points = points_in_common_view(cameras, 30, rng)
    path = Path(tempfile.mkdtemp()) / "calibration.json"
    calibrate_rig(points, observe_all(cameras, points, rng)).calibration.save(path)
    calibration = StereoCalibration.load(path)

test = np.array([[0.8, 0.05, 0.3], [1.0, -0.1, 0.35]])  # points in the calibration's frame (m)
for camera in calibration.cameras:
    d = camera.decompose()  # K (3x3, pixels), R (3x3), t (3,): P ~ K [R | t]
    rvec = Rotation.from_matrix(d.R).as_rotvec()
    print(
        f"{camera.name}: fx {d.K[0, 0]:.1f} px, fy {d.K[1, 1]:.1f} px, centre ({d.K[0, 2]:.1f}, {d.K[1, 2]:.1f}) px, "
        f"rvec {np.round(rvec, 4)}, tvec {np.round(d.t, 4)} m"
    )
    ours = camera.project(test)
    try:
        import cv2
    except ImportError:
        print(f"  projected (wiithrow): {np.round(ours, 2).tolist()} px (install OpenCV to compare)")
        continue
    theirs, _ = cv2.projectPoints(test, rvec, d.t, d.K, np.zeros(5))
    gap = np.abs(theirs.reshape(-1, 2) - ours).max()
    # OpenCV's camera matrix has no skew term: a DLT fit has a small one (K[0, 1]), which is the gap.
    print(f"  cv2.projectPoints agrees with P to {gap:.3f} px (OpenCV leaves out K's skew, {d.K[0, 1]:.2f} px here)")
