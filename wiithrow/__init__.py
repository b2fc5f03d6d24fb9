"""wiithrow: two to four Wiimotes as a calibrated stereo IR camera, and a robot arm that throws a
ball at what they see (Petric, Gams, Ude and Zlajpah, 2010).

The layers, lowest first (each imports only from the ones below it; `pyproject.toml`'s
import-linter contract enforces it, `docs/architecture.md` is the map):

* `wiithrow.clock`, `wiithrow.listeners`, `wiithrow.lazy_exports`: injectable time, listeners of a
  stream of events, a package's names imported when first read; shared by every layer;
* `wiithrow.vision`, `wiithrow.robot`: the leaves, independent of each other: cameras, calibration,
  triangulation, tracking and the Wiimote's HID protocol; arms, kinematics and trajectories;
* `wiithrow.throwing`: ballistics, the trained throws, planning and the independent validator;
* `wiithrow.app`: the running system: worlds (simulated, hardware), calibration, alignment,
  throws, the operator's session, studies;
* `wiithrow.web`: the operator's dashboard;
* `wiithrow.app.cli`: the `wiithrow` command line, the only layer that imports the dashboard.

Importing `wiithrow` imports none of them: `import wiithrow.vision` (and so on) takes what it needs.
"""

from importlib.metadata import PackageNotFoundError, version

try:
    __version__ = version("wiithrow")
except PackageNotFoundError:  # imported from a checkout that was never installed
    __version__ = "0+unknown"

__all__ = ["__version__"]
