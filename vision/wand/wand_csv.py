"""The wand CSV: one row per frame, the time then each camera's two dots.

    t, c0_a_u, c0_a_v, c0_b_u, c0_b_v, c1_a_u, c1_a_v, c1_b_u, c1_b_v, ...

Pixels as the remotes report them (u to the right, v down, 0..1023 x 0..767); NaN or an empty cell
where a camera did not see an LED; the a/b order is arbitrary per camera and frame (the LEDs look
alike: `wiithrow.vision.wand.ends` resolves it). The header line is required: it says how many
cameras there are, and a file whose columns are not in this order is refused rather than read
wrongly. Written atomically (`wiithrow.vision.files`); every error names the file and the line.
"""

from __future__ import annotations

import csv
import io
import math
import os
from pathlib import Path

import numpy as np

from wiithrow.vision.errors import FileFormatError
from wiithrow.vision.files import atomic_write_text, read_text
from wiithrow.vision.wand.observations import WandObservations


def header(cameras: int) -> list[str]:
    """The column names for `cameras` cameras."""
    return ["t"] + [f"c{c}_{end}_{axis}" for c in range(cameras) for end in "ab" for axis in "uv"]


def wand_csv_text(observations: WandObservations) -> str:
    """The observations as the wand CSV's text (NaN for what was not seen)."""
    text = io.StringIO()
    writer = csv.writer(text, lineterminator="\n")
    writer.writerow(header(observations.cameras))
    x = observations.pixels.transpose(1, 0, 2, 3).reshape(observations.frames, -1)  # (N, C * 4)
    for t, row in zip(observations.t, x):
        writer.writerow([repr(float(t))] + ["nan" if math.isnan(v) else repr(float(v)) for v in row])
    return text.getvalue()


def write_wand_csv(path: str | os.PathLike[str], observations: WandObservations) -> Path:
    """Write the observations as the wand CSV, atomically."""
    return atomic_write_text(path, wand_csv_text(observations))


def read_wand_csv(path: str | os.PathLike[str]) -> WandObservations:
    """Read a wand CSV; `FileFormatError` naming the file (and the line) when it is not one."""
    rows = list(csv.reader(io.StringIO(read_text(path))))
    rows = [r for r in rows if any(cell.strip() for cell in r)]
    if not rows:
        raise FileFormatError(f"{path}: empty; a wand CSV starts with the header {','.join(header(2))},...")
    names = [cell.strip() for cell in rows[0]]
    cameras = (len(names) - 1) // 4
    if cameras < 2 or names != header(cameras):
        raise FileFormatError(
            f"{path}: line 1 must be the header t,c0_a_u,c0_a_v,c0_b_u,c0_b_v,c1_a_u,... for 2 or more "
            f"cameras; found {','.join(names[:9])}{',...' if len(names) > 9 else ''}"
        )
    values = np.full((len(rows) - 1, len(names)), np.nan)
    for i, row in enumerate(rows[1:]):
        if len(row) != len(names):
            raise FileFormatError(f"{path}: line {i + 2} has {len(row)} columns, the header {len(names)}")
        for j, cell in enumerate(row):
            cell = cell.strip()
            if cell == "":
                continue
            try:
                values[i, j] = float(cell)
            except ValueError:
                raise FileFormatError(f"{path}: line {i + 2}, column {names[j]}: {cell!r} is not a number") from None
    if not np.isfinite(values[:, 0]).all():
        raise FileFormatError(f"{path}: every row needs a finite time t")
    if np.isinf(values).any():
        raise FileFormatError(f"{path}: contains inf; use NaN or an empty cell where a camera saw nothing")
    pixels = values[:, 1:].reshape(len(values), cameras, 2, 2).transpose(1, 0, 2, 3)
    try:
        return WandObservations(values[:, 0], pixels)
    except ValueError as exc:
        raise FileFormatError(f"{path}: {exc}") from None
