"""Two throw libraries compared on what both can be judged on, before a new one is put in use.

`compare_libraries(new, old, arm)` measures each library the same way and says whether the new
one is better (`Comparison.better`), and if not why (`Comparison.reasons`). The three figures:

* **the held-out error**: both measured by one method: each fold refitted
  (`generalize.regression_leave_one_out_error`, what `wiithrow train` prints) when both have at
  most `REFIT_MAX_THROWS` throws; otherwise, for both, the closed form with the hyperparameters fixed
  (`throwing.online_heldout`: a refit of 200 folds of 200 throws would take minutes). The new one is
  worse when its mean is larger than the old one's by more than `WORSE_BY_M`;
* **the area each covers**: the hull of its measured landings. The new one falls short when its
  hull holds less than `COVERS_SHARE` of the old one's (targets outside it are refused);
* **the number of throws**: an area needs one throw per `AREA_PER_THROW_M2` of its hull, and at
  least `MIN_MEASURED` (`throws_needed`): the paper's 25 throws over x 1.0-1.6 m, z 0-0.4 m (0.24
  m^2, hull about 0.23 m^2 of landings) are one per 0.0096 m^2, a throw per 10 cm x 10 cm.

A library with fewer throws than its area needs, a worse held-out error or a smaller area is not
put into use without an explicit choice (`LibraryChoice`: the dashboard's dialog, the command's
`--use` or `--use-if-better`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from wiithrow.app.throws.library_store import AreaFigures, Heldout
from wiithrow.app.throws.training_run import MIN_MEASURED
from wiithrow.robot import ArmModel
from wiithrow.throwing import ThrowingError, ThrowLibrary, regression_leave_one_out_error
from wiithrow.throwing.generalize import TrainedArea
from wiithrow.throwing.online import OnlineLibrary
from wiithrow.throwing.online_heldout import heldout_errors

#: The area (m^2 of the landings' hull) one throw labels: the paper's 25 over 0.24 m^2 (module docstring).
AREA_PER_THROW_M2 = 0.01
#: A held-out mean larger than the other's by more than this (m) is worse: about what the rig's
#: measurement of a landing marker resolves (true calibration: 1-2 mm), so that two trainings of one
#: area are not told apart by noise.
WORSE_BY_M = 0.001
#: The share of the old library's area the new one must cover not to fall short.
COVERS_SHARE = 0.9
#: Up to this many throws each, both libraries' held-out errors are refitted per fold (the shipped
#: 25-throw library: 0.45 s; 40 throws about 3 s); beyond it both use the closed form.
REFIT_MAX_THROWS = 40
#: The grid (per axis) over the old hull's bounds on which the share the new hull covers is counted.
_COVER_GRID = 60


def throws_needed(area: AreaFigures | None) -> int:
    """How many throws a library over `area` needs (module docstring)."""
    if area is None:
        return MIN_MEASURED
    return max(MIN_MEASURED, math.ceil(area.hull_m2 / AREA_PER_THROW_M2 - 1e-9))


@dataclass(frozen=True)
class LibraryFigures:
    """One side of a comparison: what the library is called (`label`: "version 7", "the new
    library", ...), its throws, held-out error, area and the throws that area needs."""

    label: str
    throws: int
    heldout: Heldout
    area: AreaFigures | None

    @property
    def needed(self) -> int:
        return throws_needed(self.area)

    def to_dict(self) -> dict[str, object]:
        return {
            "label": self.label,
            "throws": self.throws,
            "throws_needed": self.needed,
            "heldout": self.heldout.to_dict(),
            "area": None if self.area is None else self.area.to_dict(),
        }


@dataclass(frozen=True)
class Comparison:
    """The new library against the one in use (`old`, None when nothing was in use): the share of
    the old one's area the new one covers, and why the new one is not better (empty: it is)."""

    new: LibraryFigures
    old: LibraryFigures | None
    covers_old: float | None
    reasons: tuple[str, ...]

    @property
    def better(self) -> bool:
        return not self.reasons

    def verdict(self) -> str:
        """One line: better, or why not."""
        if self.better:
            against = f" than {self.old.label}" if self.old is not None else ""
            return f"{self.new.label} is better{against} on every figure"
        return f"{self.new.label} is not better: " + "; ".join(self.reasons)

    def rows(self) -> list[tuple[str, str, str]]:
        """(figure, new, old) rows of the table both the page and the command line show."""
        old = self.old

        def heldout(f: LibraryFigures) -> str:
            return f"{1e3 * f.heldout.mean_m:.1f} mm (max {1e3 * f.heldout.max_m:.1f})"

        def area(f: LibraryFigures) -> str:
            return f.area.line() if f.area is not None else "none (fewer than 3 landings)"

        covers = "" if self.covers_old is None else f" ({100 * self.covers_old:.0f} % of the other)"
        return [
            ("", self.new.label, old.label if old else "(none in use)"),
            ("held-out error, mean", heldout(self.new), heldout(old) if old else ""),
            ("area covered", area(self.new) + covers, area(old) if old else ""),
            ("throws (its area needs)", f"{self.new.throws} ({self.new.needed})", f"{old.throws} ({old.needed})" if old else ""),
            ("held-out method", self.new.heldout.method, old.heldout.method if old else ""),
        ]  # fmt: skip

    def to_dict(self) -> dict[str, object]:
        return {
            "new": self.new.to_dict(),
            "in_use": None if self.old is None else self.old.to_dict(),
            "covers_in_use_share": self.covers_old,
            "better": self.better,
            "reasons": list(self.reasons),
        }


@dataclass(frozen=True)
class LibraryChoice:
    """A finished training's library waiting for the operator's choice: the `library`, its
    version in the library folder (None without a folder) and the comparison shown."""

    library: ThrowLibrary
    version: int | None
    comparison: Comparison


def heldout_of(library: ThrowLibrary, arm: ArmModel, method: str) -> Heldout:
    """`library`'s held-out error by `method` ("refit" or "fixed": module docstring)."""
    if method == "refit":
        return Heldout.of(regression_leave_one_out_error(library, arm).errors, "refit")
    return Heldout.of(heldout_errors(OnlineLibrary.start(library), arm), "fixed")


def covered_share(new: ThrowLibrary, old: ThrowLibrary) -> float | None:
    """The share of `old`'s hull inside `new`'s (counted on a grid), None when either has none."""
    try:
        a, b = TrainedArea(new.landings), TrainedArea(old.landings)
    except ThrowingError:
        return None
    (x0, x1), (z0, z1) = b.bounds
    X, Z = np.meshgrid(np.linspace(x0, x1, _COVER_GRID), np.linspace(z0, z1, _COVER_GRID))
    points = np.column_stack([X.ravel(), Z.ravel()])
    inside_old = points[_inside(b, points)]
    if len(inside_old) == 0:
        return None
    return float(np.mean(_inside(a, inside_old)))


def _inside(area: TrainedArea, points: np.ndarray) -> np.ndarray:
    """Which of `points` (M, 2) lie in `area`'s hull (its facets' half-planes, a nanometre's slack)."""
    return np.all(points @ area.equations[:, :2].T + area.equations[:, 2] <= 1e-9, axis=1)


def compare_libraries(
    new: ThrowLibrary,
    old: ThrowLibrary | None,
    arm: ArmModel,
    *,
    new_label: str = "the new library",
    old_label: str = "the library in use",
    new_refit: Heldout | None = None,
) -> Comparison:
    """`new` against `old` (module docstring); `new_refit`: the new library's refitted held-out
    error when it is already known (Finish computed it)."""
    method = "refit" if len(new) <= REFIT_MAX_THROWS and (old is None or len(old) <= REFIT_MAX_THROWS) else "fixed"
    new_heldout = new_refit if (new_refit is not None and method == "refit") else heldout_of(new, arm, method)
    new_figures = LibraryFigures(new_label, len(new), new_heldout, AreaFigures.of(new))
    reasons: list[str] = []
    if new_figures.throws < new_figures.needed:
        reasons.append(
            f"{new_figures.throws} throws, fewer than its area needs ({new_figures.needed}: one per "
            f"{1e4 * AREA_PER_THROW_M2:.0f} cm^2, at least {MIN_MEASURED})"
        )
    if old is None:
        return Comparison(new_figures, None, None, tuple(reasons))
    old_figures = LibraryFigures(old_label, len(old), heldout_of(old, arm, method), AreaFigures.of(old))
    if not new_heldout.mean_m <= old_figures.heldout.mean_m + WORSE_BY_M:
        reasons.append(
            f"its held-out error is worse ({1e3 * new_heldout.mean_m:.1f} mm against {1e3 * old_figures.heldout.mean_m:.1f} "
            "mm)"
        )
    share = covered_share(new, old)
    if share is not None and share < COVERS_SHARE:
        reasons.append(f"it covers {100 * share:.0f} % of the area of {old_label} (targets outside it are refused)")
    return Comparison(new_figures, old_figures, share, tuple(reasons))


def table_text(comparison: Comparison) -> list[str]:
    """The comparison as aligned text lines (the command line's table)."""
    rows = comparison.rows()
    widths = [max(len(r[k]) for r in rows) for k in range(3)]
    return ["  ".join(cell.ljust(w) for cell, w in zip(row, widths)).rstrip() for row in rows]


def table_markdown(comparison: Comparison) -> str:
    """The comparison as a markdown table (the page's dialog)."""
    rows = comparison.rows()
    head, *body = rows
    lines = [f"| | {head[1]} | {head[2]} |", "|---|---|---|"]
    lines += [f"| {a} | {b} | {c} |" for a, b, c in body]
    return "\n".join(lines)
