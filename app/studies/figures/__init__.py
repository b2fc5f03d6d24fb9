"""The paper's figures, reproduced on the simulated system (used by `wiithrow.app.studies.reproduce`).

One module per figure, each owning its data (gathered from the simulated arm and remotes or
from measured poses), its CSV and its PNG:

- `accuracy`: Fig. 4, mean leave-one-out 3D error against the number of calibration points;
- `positions`: Fig. 5, actual (forward kinematics) against calculated (stereo) positions;
- `mono`: Fig. 6, the mono method against the stereo rig while the beacon pair turns.

This module holds what they share: files written atomically, and matplotlib without a display
(the object-oriented `Figure` API renders through Agg; pyplot's global state is never touched).
"""

from __future__ import annotations

import csv
import io
import os
from collections.abc import Iterable, Sequence
from pathlib import Path

from wiithrow.vision.files import atomic_write_bytes, atomic_write_text


def new_figure(width_in: float = 7.0, height_in: float = 4.5):
    """A matplotlib Figure drawn by the Agg backend (no display needed)."""
    from matplotlib.figure import Figure

    return Figure(figsize=(width_in, height_in), layout="constrained")


def save_png(figure, path: str | os.PathLike[str], dpi: int = 110) -> Path:
    """Render `figure` to PNG and write it atomically."""
    buffer = io.BytesIO()
    figure.savefig(buffer, format="png", dpi=dpi)
    return atomic_write_bytes(path, buffer.getvalue())


def write_csv(path: str | os.PathLike[str], header: Sequence[str], rows: Iterable[Sequence[object]]) -> Path:
    """Write a CSV atomically (floats with repr precision, NaN as 'nan')."""
    text = io.StringIO()
    writer = csv.writer(text, lineterminator="\n")
    writer.writerow(header)
    for row in rows:
        writer.writerow([repr(float(v)) if isinstance(v, float) else v for v in row])
    return atomic_write_text(path, text.getvalue())
