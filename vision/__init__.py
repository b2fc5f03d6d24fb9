"""Stereo vision with Wiimote IR cameras.

The geometry (camera model, DLT calibration, N-view triangulation, the mono method, leave-one-out
cross-validation) and the Wiimote itself (HID protocol, driver, simulated remote). Depends only on
numpy, scipy and hidapi; never imports `robot` or anything above it.

The names below are imported when first used (`wiithrow.lazy_exports`): a process that needs one
module of the package (a publisher's writer process, `vision.files`) does not pay for scipy's
optimisers and the numba kernels the others import.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from wiithrow.lazy_exports import lazy_exports

if TYPE_CHECKING:
    from wiithrow.vision.camera import WiimoteCamera, look_at_rotation
    from wiithrow.vision.crossval import leave_one_out
    from wiithrow.vision.dlt import CalibratedCamera, calibrate
    from wiithrow.vision.errors import CalibrationError, FileFormatError, TriangulationError, VisionError
    from wiithrow.vision.geometry import Decomposition
    from wiithrow.vision.mono import mono_position
    from wiithrow.vision.stereo_calibration import StereoCalibration, load_dlt_coefficients, save_dlt_coefficients
    from wiithrow.vision.triangulation import Triangulation, triangulate

#: Each public name and the module that defines it.
_HOMES = {
    "WiimoteCamera": "camera",
    "look_at_rotation": "camera",
    "leave_one_out": "crossval",
    "CalibratedCamera": "dlt",
    "calibrate": "dlt",
    "CalibrationError": "errors",
    "FileFormatError": "errors",
    "TriangulationError": "errors",
    "VisionError": "errors",
    "Decomposition": "geometry",
    "mono_position": "mono",
    "StereoCalibration": "stereo_calibration",
    "load_dlt_coefficients": "stereo_calibration",
    "save_dlt_coefficients": "stereo_calibration",
    "Triangulation": "triangulation",
    "triangulate": "triangulation",
}

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


__getattr__, __dir__ = lazy_exports(__name__, _HOMES)
