"""CSV files of calibration and image points.

Calibration points: one row per 3D point, columns x, y, z (metres) then u, v for each camera
(pixels), NaN (or an empty cell) where a camera did not see the point. Image points for
triangulation: u, v per camera. A header line is optional.
"""

from __future__ import annotations

import csv
import io
import os
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from wiithrow.app.errors import AppError


def read_numeric_csv(path: str | os.PathLike[str], *, min_columns: int) -> NDArray[np.float64]:
    """Rows of floats (empty cells and 'nan' are NaN); one optional header line is skipped."""
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise AppError(f"{path}: no such file") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise AppError(f"{path}: cannot be read ({exc})") from None
    rows: list[list[float]] = []
    for number, record in enumerate(csv.reader(io.StringIO(text)), start=1):
        if not record or all(not cell.strip() for cell in record):
            continue
        try:
            rows.append([float(cell) if cell.strip() else float("nan") for cell in record])
        except ValueError:
            if number == 1 and not rows:
                continue  # a header line
            raise AppError(f"{path}, line {number}: not a number in {record}") from None
    if not rows:
        raise AppError(f"{path}: no data rows")
    widths = {len(r) for r in rows}
    if len(widths) != 1:
        raise AppError(f"{path}: rows have different numbers of columns ({sorted(widths)})")
    data = np.array(rows)
    if data.shape[1] < min_columns:
        raise AppError(f"{path}: expected at least {min_columns} columns, found {data.shape[1]}")
    return data


def read_calibration_points(path: str | os.PathLike[str]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """World points (N, 3) and pixels (C, N, 2) from a calibration CSV (x, y, z, u0, v0, u1, v1, ...)."""
    data = read_numeric_csv(path, min_columns=7)
    if (data.shape[1] - 3) % 2:
        raise AppError(f"{path}: after x, y, z there must be a u, v pair per camera ({data.shape[1]} columns)")
    world = data[:, :3]
    if not np.isfinite(world).all():
        raise AppError(f"{path}: every row needs finite x, y, z (a calibration point's position is known)")
    image = data[:, 3:].reshape(len(data), -1, 2).transpose(1, 0, 2)
    return world, image


def read_image_points(path: str | os.PathLike[str], cameras: int) -> NDArray[np.float64]:
    """Pixels (C, N, 2) from a CSV with a u, v pair per camera per row."""
    data = read_numeric_csv(path, min_columns=2 * cameras)
    if data.shape[1] != 2 * cameras:
        raise AppError(
            f"{path}: expected {2 * cameras} columns (u, v for each of {cameras} cameras), found {data.shape[1]}"
        )
    return data.reshape(len(data), cameras, 2).transpose(1, 0, 2)


def write_calibration_points(
    path: str | os.PathLike[str], world: NDArray[np.float64], image: NDArray[np.float64]
) -> None:
    """Inverse of `read_calibration_points` (with a header line)."""
    from wiithrow.vision.files import atomic_write_text

    cameras = image.shape[0]
    header = ["x", "y", "z"] + [f"{axis}{c}" for c in range(cameras) for axis in ("u", "v")]
    out = io.StringIO()
    writer = csv.writer(out, lineterminator="\n")
    writer.writerow(header)
    for i in range(len(world)):
        writer.writerow([repr(float(v)) for v in world[i]] + [repr(float(v)) for v in image[:, i].ravel()])
    atomic_write_text(path, out.getvalue())
