"""Stereo vision with Wiimote IR cameras.

The geometry (camera model, DLT calibration, N-view triangulation, the mono method, leave-one-out
cross-validation) and the Wiimote itself (HID protocol, driver, simulated remote). Depends only on
numpy, scipy and hidapi; never imports `robot` or anything above it.
"""

from wiithrow.vision.camera import WiimoteCamera, look_at_rotation
from wiithrow.vision.crossval import leave_one_out
from wiithrow.vision.dlt import CalibratedCamera, calibrate
from wiithrow.vision.errors import CalibrationError, FileFormatError, TriangulationError, VisionError
from wiithrow.vision.geometry import Decomposition
from wiithrow.vision.mono import mono_position
from wiithrow.vision.stereo_calibration import StereoCalibration, load_dlt_coefficients, save_dlt_coefficients
from wiithrow.vision.triangulate import Triangulation, triangulate

__all__ = [
    "CalibratedCamera",
    "CalibrationError",
    "Decomposition",
    "FileFormatError",
    "StereoCalibration",
    "Triangulation",
    "TriangulationError",
    "VisionError",
    "WiimoteCamera",
    "calibrate",
    "leave_one_out",
    "load_dlt_coefficients",
    "look_at_rotation",
    "mono_position",
    "save_dlt_coefficients",
    "triangulate",
]
