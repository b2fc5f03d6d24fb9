"""The metric scale from the wand's length, and the checks that the length fits the data.

Images determine a rig only up to scale: multiply every position (cameras and points) by s and
every pixel stays where it was. The wand gives the scale. A reconstruction in which the wand's
ends come out lengths l_k apart is made metric by

    s = L / median_k(l_k)

(the median: a few mislabelled frames do not move it). Each camera pair of the initial chain is
scaled this way on its own frames, so the chain needs no scale transfer between pairs; the bundle
adjustment then keeps the length at L exactly (it is built into the wand's parametrisation).

The scale cannot tell a wrong length from a right one, since any L fits the pixels equally well.
What can be checked:

* the unit: with the length given, the wand's depth follows from its image length,
  depth ~ f L / (pixel separation); a Wiimote sees IR LEDs from about 0.1 m to a few metres, so
  a length that puts the wand at 60 m (millimetres typed for metres) is refused (`check_depths`);
* LEDs too close together for their images to be told apart reliably (`check_separation`);
* a second metric source: the robot's forward kinematics (`--frame robot`) or an L-frame of known
  size give the scale of the calibrated rig independently; a scale away from 1 means the length
  was wrong, and the message says which length the data imply (`check_scale`).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from wiithrow.vision.errors import WandLengthError

#: Depths (m) at which a Wiimote can see an IR LED: below, the LED is a blur; beyond, too faint.
PLAUSIBLE_DEPTH_M = (0.05, 15.0)
#: The wand's two dots closer than this (px, median over the frames) cannot be told apart reliably.
MIN_SEPARATION_PX = 15.0
#: A second metric source that disagrees with the wand's scale by more than this is an error.
SCALE_TOLERANCE = 0.02


def wand_scale(lengths: NDArray[np.float64], wand_length_m: float) -> float:
    """s = L / median(l) over the finite lengths (see the module docstring)."""
    finite = lengths[np.isfinite(lengths) & (lengths > 0)]
    if finite.size == 0:
        raise WandLengthError("no frame gives the wand a length: the two cameras' dots do not form one wand")
    return float(wand_length_m / np.median(finite))


def check_depths(depths_m: NDArray[np.float64], wand_length_m: float) -> None:
    """Refuse a length that puts the wand where a Wiimote cannot see it (the median depth)."""
    depth = float(np.nanmedian(depths_m))
    low, high = PLAUSIBLE_DEPTH_M
    if not low <= depth <= high:
        raise WandLengthError(
            f"with a wand length of {wand_length_m:g} m the wand would be {depth:.3g} m from the cameras, "
            f"where a Wiimote cannot see it ({low:g}-{high:g} m): give the distance between the LED centres "
            "in metres"
        )


def check_separation(pixels: NDArray[np.float64], names: list[str]) -> None:
    """Refuse data in which a camera sees the two LEDs (C, N, 2, 2) too close together."""
    for c, name in enumerate(names):
        d = np.linalg.norm(pixels[c, :, 0] - pixels[c, :, 1], axis=1)
        d = d[np.isfinite(d)]
        if d.size and float(np.median(d)) < MIN_SEPARATION_PX:
            raise WandLengthError(
                f"{name} sees the wand's LEDs only {np.median(d):.0f} px apart (median): too close to tell "
                f"them apart (at least {MIN_SEPARATION_PX:g} px); use a longer wand or wave it closer"
            )


def check_scale(scale: float, wand_length_m: float, source: str) -> None:
    """Refuse a calibration whose scale a second metric source (`source`) puts away from 1: the
    wand length was wrong. `scale` maps the wand calibration's lengths to the source's."""
    if abs(scale - 1.0) > SCALE_TOLERANCE:
        raise WandLengthError(
            f"the wand length {wand_length_m:g} m does not fit the data: {source} measures the rig "
            f"{scale:.3f} times as large, i.e. a wand of {scale * wand_length_m:.3f} m; measure the wand again"
        )
