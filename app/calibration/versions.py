"""A new calibration beside the one it replaces: its figures side by side, the old one kept.

`CalibrationFigures.of(calibration)`: what a person compares two calibrations by: the fingerprint
(`StereoCalibration.fingerprint`, what a library's versions record), the frame and arm, the
cameras with their fitted points and reprojection RMS (px), the leave-one-out 3D error (mm) where
known. `side_by_side(new, old)` puts two of them in rows (the command line prints them; the
dashboard's Library folder shows the calibration in use beside the one it replaced).

`keep_replaced(path)`: before a command writes a calibration over an existing file, that file is
copied, unchanged, to `<stem>.versions/<stem>-<fingerprint>.json` beside it (atomically; a copy
already there is not written again): every calibration a lab replaced stays on disk. Calibrations
are made a few times a year, so nothing thins them.
"""

from __future__ import annotations

import os
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from wiithrow.vision import StereoCalibration, VisionError
from wiithrow.vision.files import CALIBRATION_SIZE, atomic_write_bytes


@dataclass(frozen=True)
class CalibrationFigures:
    """A calibration's figures (module docstring); `points` and `rms_px` per camera."""

    fingerprint: str
    frame: str
    arm: str | None
    points: tuple[int, ...]
    rms_px: tuple[float, ...]
    loo_mm: float | None

    @classmethod
    def of(cls, calibration: StereoCalibration) -> CalibrationFigures:
        loo = calibration.loo_error_m
        return cls(
            calibration.fingerprint,
            calibration.frame,
            calibration.arm,
            tuple(int(c.world.shape[0]) for c in calibration.cameras),
            tuple(float(c.rms_px) for c in calibration.cameras),
            None if loo is None else 1e3 * float(loo),
        )

    def cells(self) -> tuple[str, ...]:
        """The figures as the rows of `side_by_side` show them."""
        rms = ", ".join("-" if not np.isfinite(r) else f"{r:.2f}" for r in self.rms_px)
        return (
            self.fingerprint,
            f"{self.frame} ({self.arm or 'no arm said'})",
            f"{len(self.points)}: {', '.join(str(p) for p in self.points)} points",
            rms,
            "unknown" if self.loo_mm is None else f"{self.loo_mm:.2f}",
        )


ROWS = ("fingerprint", "frame (arm)", "cameras", "reprojection RMS (px)", "leave-one-out 3D error (mm)")


def side_by_side(new: CalibrationFigures, old: CalibrationFigures | None) -> list[tuple[str, str, str]]:
    """(figure, new, old) rows, headed by ("", "new", "replaced")."""
    olds = old.cells() if old is not None else ("",) * len(ROWS)
    return [("", "new", "replaced" if old is not None else "(none)")] + list(zip(ROWS, new.cells(), olds))


def side_by_side_text(new: CalibrationFigures, old: CalibrationFigures | None) -> list[str]:
    rows = side_by_side(new, old)
    widths = [max(len(r[k]) for r in rows) for k in range(3)]
    return ["  ".join(cell.ljust(w) for cell, w in zip(row, widths)).rstrip() for row in rows]


def side_by_side_markdown(new: CalibrationFigures, old: CalibrationFigures | None) -> str:
    head, *body = side_by_side(new, old)
    return "\n".join([f"| | {head[1]} | {head[2]} |", "|---|---|---|", *(f"| {a} | {b} | {c} |" for a, b, c in body)])


def versions_folder(path: str | os.PathLike[str]) -> Path:
    """Where the calibrations `path` replaced are kept."""
    p = Path(path)
    return p.with_name(f"{p.stem}.versions")


def keep_replaced(path: str | os.PathLike[str]) -> tuple[CalibrationFigures, Path] | None:
    """Keep the calibration at `path` before it is replaced (module docstring): its figures and
    where it is kept; None when there is no readable calibration there (nothing to keep)."""
    p = Path(path)
    if not p.is_file():
        return None
    try:
        old = StereoCalibration.load(p)
    except VisionError:  # not a calibration we can read: the command's own checks say so
        return None
    figures = CalibrationFigures.of(old)
    kept = versions_folder(p) / f"{p.stem}-{figures.fingerprint}.json"
    if not kept.exists():
        if p.stat().st_size > CALIBRATION_SIZE.max_bytes:
            return None
        atomic_write_bytes(kept, p.read_bytes())
    return figures, kept


def keep_and_compare(path: str | os.PathLike[str], new: StereoCalibration, say: Callable[[str], None]) -> Path | None:
    """Before `new` is written over the calibration at `path`: keep that one (`keep_replaced`)
    and `say` both calibrations' figures side by side, then where the old one is kept."""
    kept = keep_replaced(path)
    if kept is None:
        return None
    old, where = kept
    for line in side_by_side_text(CalibrationFigures.of(new), old):
        say(line)
    say(f"the calibration {path} held is kept in {where}")
    return where
