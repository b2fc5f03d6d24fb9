"""The exceptions of the vision package: each says what was wrong and what to do about it."""


class VisionError(ValueError):
    """Base class of every expected failure in `vision` (bad input, bad file, bad device data)."""


class CalibrationError(VisionError):
    """The calibration data cannot give a meaningful camera (too few, degenerate or inconsistent points)."""


class TriangulationError(VisionError):
    """The cameras or image points given to triangulation are inconsistent."""


class FileFormatError(VisionError):
    """A file is missing, corrupt, of another kind or of an unsupported schema version."""


class FileTooLargeError(FileFormatError):
    """A file is larger than any file of its kind may be (`wiithrow.vision.files.SizeBound`); none
    of it was read."""


class OutputPathError(VisionError):
    """An output cannot be written where asked: a read-only or missing folder, a path under a file,
    a folder where a file should go, or an existing file the user did not ask to replace."""


class OutputWriteError(OutputPathError):
    """Writing an output failed part-way (a full disk, a quota, an I/O error); the message says
    what was kept."""


class WandError(CalibrationError):
    """A wand calibration cannot be made from these data; the message says what to do."""


class TooFewFramesError(WandError):
    """Too few frames in which two cameras saw both of the wand's LEDs."""


class WandNotSeenError(WandError):
    """A camera never saw both of the wand's LEDs, or shares no frame with the others."""


class WandLengthError(WandError):
    """The wand length given does not fit the data (a wrong length or unit, LEDs too close)."""


class DegenerateMotionError(WandError):
    """The wand's motion cannot determine the cameras (it kept one orientation: it only translated)."""
