"""A training run: the paper's training procedure on the arm at hand, one throw at a time, saved
after every step so that a Stop, a crash or a restart resumes where it was.

Owns `TrainingRun` (the state: the arm, the area of the throw plane trained, the targets and each
one's `TrainingThrow`, with what measured its landing, `Measurement`), the targets of an area
(`training_targets_for`), the area bounded by the arm's reach (`reachable_area`) and the library a
finished run fits (`library_of`). Its file (`<library>.training.json` beside the library the
session was told to write, written atomically after every change) is `training_file`'s: the run
names no path, so its file cannot say where anything is written.

Each target's throw goes through these states, in this order (the session's training operations
make the transitions; `wiithrow.app.session.refusals` says which may happen now and why not):

    pending --throw--> thrown --measure--> measured
       |  +--a Stop, a fault or a late release--> failed
       |                            |
       +<-------- retry ------------+ (from thrown or failed)
    pending | thrown | failed --skip--> skipped

The run is at its first throw that is neither measured nor skipped (`index`); it is complete
when there is none. A preview is not part of the file: after a restart the operator previews the
throw again (it is planned from the arm's pose at that moment, and a plan is used once).

A throw's label is the landing the rig measured (`measured`, (x, z) in the throw's plane: link1 at
the joint-1 angle it was thrown at, `q1`), as in the paper, and how far beside that plane it came
down (`measured_across`, the sideways term's label: `throwing.lateral`), with what measured it
(`measured_by`: the source, the calibration's fingerprint and frame, the time); `landing_base` is
the world's truth where a simulated world knows it (what its simulated operator puts the marker
on), None on hardware. Before a fit every label is checked (`landing_checks`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from datetime import UTC, datetime
from typing import Any, Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray

from wiithrow.app.errors import AppError
from wiithrow.robot import ArmModel
from wiithrow.throwing import (
    Area,
    Ball,
    ThrowLibrary,
    ThrowParameters,
    TrainedThrow,
    UnreachableTargetError,
    shape_for,
)
from wiithrow.throwing.operator import solve_throw

#: The paper's number of training throws.
DEFAULT_THROWS = 25
#: The fewest measured throws a library is fitted from: the regression needs 4 throws, and its
#: held-out error refits it without each one in turn (`throwing.regression_leave_one_out_error`).
MIN_MEASURED = 5
MAX_THROWS = 100
#: The least extent (m) of a training area in x and in z (the measured landings must span an area).
MIN_SPAN_M = 0.05
#: How far (m) from the planned release the hand may be told to open before the operator is
#: warned (the kinematic world: 1-4 mm, its release jitter).
RELEASE_WARNING_M = 0.025
#: How closely (m) `reachable_area` finds the reach.
REACH_TOLERANCE_M = 0.01

State = Literal["pending", "thrown", "failed", "measured", "skipped"]
STATES: tuple[State, ...] = ("pending", "thrown", "failed", "measured", "skipped")


#: Where a measured landing came from: the rig measured the marker the operator (or a simulated
#: world's simulated operator) put where the ball came down.
SOURCES = ("rig",)


@dataclass(frozen=True)
class Measurement:
    """What measured a landing: `source` (one of `SOURCES`), the rig's `calibration` then (its
    `StereoCalibration.fingerprint`), the `frame` the landing is in, and the `time` (ISO 8601, UTC)."""

    source: str
    calibration: str
    frame: str
    time: str

    @classmethod
    def by_rig(cls, calibration: str, frame: str) -> Measurement:
        """A landing the rig measures now, with the calibration of fingerprint `calibration`
        (`vision.stereo_calibration.calibration_fingerprint`) in `frame`."""
        return cls("rig", calibration, frame, datetime.now(UTC).isoformat(timespec="seconds"))

    def to_dict(self) -> dict[str, str]:
        return {"source": self.source, "calibration": self.calibration, "frame": self.frame, "time": self.time}


@dataclass(frozen=True)
class TrainingThrow:
    """One target's throw: `target` (x, z) in link1 (m), its `state`, the `params` thrown (once
    thrown), the world's true landing (`landing_base`, simulation only), the rig's `measured`
    landing (x, z) in the throw's plane, and `note` (why it failed, or was skipped)."""

    target: NDArray[np.float64]
    state: State = "pending"
    params: ThrowParameters | None = None
    landing_base: NDArray[np.float64] | None = None
    measured: NDArray[np.float64] | None = None
    note: str = ""
    # how far (m) the ball was from the plan's release position when the hand was told to open
    # (`ThrowExecution.release_tracking_m`): a late host or a lagging arm; None when unknown
    release_off_m: float | None = None
    # what measured `measured` (None: not measured, or a file from before it was recorded)
    measured_by: Measurement | None = None
    # joint 1's angle (rad) the throw was planned at: its plane (None: not thrown, or a file from before)
    q1: float | None = None
    # how far (m) beside the throw's plane the rig measured the landing (+ toward link1's +y; None: not measured)
    measured_across: float | None = None

    @property
    def release_warning(self) -> str:
        """A line for the operator when the throw let go far from its plan ("" otherwise)."""
        off = self.release_off_m
        if off is None or not off > RELEASE_WARNING_M:
            return ""
        return (
            f"the hand was told to open {1e3 * off:.0f} mm from the planned release (a late host or a lagging arm): "
            "its label is where that ball went; retry it to label the planned throw"
        )

    def to_dict(self) -> dict[str, Any]:
        return {
            "target": [float(v) for v in self.target],
            "state": self.state,
            "params": self.params.to_dict() if self.params is not None else None,
            "landing_base": None if self.landing_base is None else [float(v) for v in self.landing_base],
            "measured": None if self.measured is None else [float(v) for v in self.measured],
            "measured_by": None if self.measured_by is None else self.measured_by.to_dict(),
            "note": self.note,
            "release_off_m": self.release_off_m,
            "q1_rad": self.q1,
            "measured_across_m": self.measured_across,
        }


@dataclass(frozen=True)
class TrainingRun:
    """The training procedure's state (module docstring). Immutable: every step returns a new run."""

    arm: str
    area: Area
    throws: tuple[TrainingThrow, ...]
    notes: tuple[str, ...] = field(default=())  # what the operator was told at the start (e.g. a clamped area)

    @classmethod
    def start(cls, arm: str, area: Area, count: int = DEFAULT_THROWS) -> TrainingRun:
        """A new run of `count` throws over `area` (targets: `training_targets_for`)."""
        if not MIN_MEASURED <= count <= MAX_THROWS:
            raise AppError(f"the number of training throws must be {MIN_MEASURED} to {MAX_THROWS}, got {count}")
        if area.x[1] - area.x[0] < MIN_SPAN_M or area.z[1] - area.z[0] < MIN_SPAN_M:
            raise AppError(f"the training area {area} must span at least {100 * MIN_SPAN_M:.0f} cm in x and in z")
        targets = training_targets_for(area, count)
        return cls(arm, area, tuple(TrainingThrow(t) for t in targets))

    # -- where the run is ----------------------------------------------------------------------------

    @property
    def count(self) -> int:
        return len(self.throws)

    @property
    def index(self) -> int | None:
        """The current throw (0-based): the first neither measured nor skipped; None when complete."""
        for i, t in enumerate(self.throws):
            if t.state not in ("measured", "skipped"):
                return i
        return None

    @property
    def current(self) -> TrainingThrow | None:
        i = self.index
        return None if i is None else self.throws[i]

    @property
    def complete(self) -> bool:
        return self.index is None

    @property
    def measured(self) -> int:
        return sum(t.state == "measured" for t in self.throws)

    @property
    def skipped(self) -> int:
        return sum(t.state == "skipped" for t in self.throws)

    def progress_line(self) -> str:
        """ "throw 3/25 · measured 2 · skipped 0" (or "all 25 throws done · ..." once complete)."""
        i = self.index
        head = f"throw {i + 1}/{self.count}" if i is not None else f"all {self.count} throws done"
        state = self.current.state if self.current is not None else ""
        tail = f" ({state})" if state in ("thrown", "failed") else ""
        return f"{head}{tail} · measured {self.measured} · skipped {self.skipped}"

    # -- the steps (each checked again here: the session's refusals said whether they may happen) -------

    def _with_current(self, expected: tuple[State, ...], **changes: Any) -> TrainingRun:
        i = self.index
        if i is None:
            raise AppError("the training run is complete: finish it")
        throw = self.throws[i]
        if throw.state not in expected:
            raise AppError(f"throw {i + 1} is {throw.state}, not {' or '.join(expected)}")
        return replace(self, throws=(*self.throws[:i], replace(throw, **changes), *self.throws[i + 1 :]))

    def thrown(
        self,
        params: ThrowParameters,
        landing_base: ArrayLike | None,
        release_off_m: float | None = None,
        q1: float | None = None,
    ) -> TrainingRun:
        """The current throw was thrown with `params` (the ball came down at `landing_base`, if
        known; the hand was told to open `release_off_m` from the planned release, if known), with
        joint 1 at `q1` (rad, its plane)."""
        land = None if landing_base is None else np.asarray(landing_base, dtype=float).reshape(3)
        if land is not None and not np.isfinite(land).all():
            land = None
        off = float(release_off_m) if release_off_m is not None and np.isfinite(release_off_m) else None
        return self._with_current(
            ("pending",),
            state="thrown",
            params=params,
            landing_base=land,
            note="",
            release_off_m=off,
            q1=None if q1 is None else float(q1),
        )

    def failed(self, reason: str) -> TrainingRun:
        """The current throw ended early (a Stop, a fault) or was released late (its landing labels
        nothing): it is retried or skipped next."""
        return self._with_current(("pending", "thrown"), state="failed", note=reason)

    def landed(self, measured_xz: ArrayLike, measured_by: Measurement, across_m: float | None = None) -> TrainingRun:
        """The current throw's landing marker was measured at `measured_xz` (its plane, m),
        `across_m` beside it (m, if measured), as `measured_by` says: its labels."""
        m = _finite(measured_xz, 2, "measured landing")
        across = None if across_m is None else float(_finite([across_m], 1, "measured across offset")[0])
        return self._with_current(
            ("thrown",), state="measured", measured=m, measured_by=measured_by, measured_across=across
        )

    def refused(self, index: int, reason: str) -> TrainingRun:
        """Throw `index`'s measured landing is refused (`landing_checks`): the throw is failed, and
        the run is at it again (the first throw neither measured nor skipped) to retry or skip it."""
        throw = replace(
            self.throws[index], state="failed", measured=None, measured_by=None, measured_across=None, note=reason
        )
        return replace(self, throws=(*self.throws[:index], throw, *self.throws[index + 1 :]))

    def retried(self) -> TrainingRun:
        """Throw the current throw again (what it did is forgotten)."""
        return self._with_current(
            ("thrown", "failed"),
            state="pending",
            params=None,
            landing_base=None,
            measured=None,
            measured_by=None,
            note="",
            release_off_m=None,
            q1=None,
            measured_across=None,
        )

    def skip(self, reason: str = "skipped by the operator") -> TrainingRun:
        """Leave the current throw out of the library."""
        return self._with_current(
            ("pending", "thrown", "failed"),
            state="skipped",
            measured=None,
            measured_by=None,
            measured_across=None,
            note=reason,
        )

    def to_dict(self) -> dict[str, Any]:
        """The run as its progress file holds it (`training_file`: kind and schema added there)."""
        return {
            "arm": self.arm,
            "area": {"x_m": list(self.area.x), "z_m": list(self.area.z)},
            "notes": list(self.notes),
            "throws": [t.to_dict() for t in self.throws],
        }


@dataclass(frozen=True)
class TrainingOutcome:
    """A finished run: where the library was written (`path`: its version's file, or the file the
    command named), its version in the library folder (None without one), its throws, the
    regression's held-out error (leave-one-out, as `wiithrow train` prints it: mean, median, max,
    m), the area it covers, and whether it was put in use (`used`; None: waiting for the
    operator's choice, `wiithrow.app.throws.library_compare`), with the comparison's verdict."""

    path: str
    throws: int
    skipped: int
    heldout_mean_m: float
    heldout_median_m: float
    heldout_max_m: float
    covers: str  # `TrainedArea.describe()`: the hull of the measured landings
    version: int | None = None
    used: bool | None = None
    verdict: str = ""

    def summary(self) -> str:
        return (
            f"{self.throws} throws ({self.skipped} skipped) saved to {self.path}; the regression's held-out error "
            f"(leave-one-out) mean {1e3 * self.heldout_mean_m:.1f} mm, median {1e3 * self.heldout_median_m:.1f} mm, "
            f"max {1e3 * self.heldout_max_m:.1f} mm; covers {self.covers}"
        )

    def decided(self, used: bool) -> TrainingOutcome:
        """This outcome once the operator chose (`used`: the new library is in use)."""
        return replace(self, used=bool(used))


def library_of(run: TrainingRun, arm: ArmModel, ball: Ball, meta: dict[str, object] | None = None) -> ThrowLibrary:
    """The library of the run's measured throws (label: the measured landing), for `arm` and `ball`;
    its meta says what measured the labels (sources and calibrations, or how many did not say)."""
    trained = [
        TrainedThrow(t.target, t.params, t.measured, t.measured_across)
        for t in run.throws
        if t.state == "measured" and t.params is not None and t.measured is not None
    ]
    if len(trained) < MIN_MEASURED:
        raise AppError(f"measure at least {MIN_MEASURED} throws before fitting ({len(trained)} measured)")
    info: dict[str, object] = {
        "trained_by": "wiithrow.app.throws.training_run (the operator's training on this arm)",
        "targets": run.count,
        "measured": len(trained),
        "skipped": run.skipped,
        "area_x_m": list(run.area.x),
        "area_z_m": list(run.area.z),
        "measured_by": _measured_by(run),
        **(meta or {}),
    }
    return ThrowLibrary(arm.name, shape_for(arm), ball, tuple(trained), info)


def _measured_by(run: TrainingRun) -> dict[str, object]:
    """What measured the run's labels: the sources and calibrations (fingerprint: throws), and the
    throws whose file did not record it (measured before it was recorded)."""
    by = [t.measured_by for t in run.throws if t.state == "measured"]
    calibrations: dict[str, int] = {}
    for m in by:
        if m is not None:
            calibrations[m.calibration] = calibrations.get(m.calibration, 0) + 1
    return {
        "sources": sorted({m.source for m in by if m is not None}),
        "calibrations": calibrations,
        "unrecorded": sum(m is None for m in by),
    }


# -- the targets and the area ---------------------------------------------------------------------------


def training_targets_for(area: Area, count: int) -> NDArray[np.float64]:
    """(count, 2) targets (x, z) over `area`, corners included: the nx x nz grid with the fewest
    points beyond `count` among those within a factor 2.5 of the area's aspect (25: the paper's
    5 x 5; 6: 3 x 2; 7: 4 x 2), thinned to `count` points by
    farthest-point order from the corners (every point taken is the grid point farthest from
    those taken before), listed row by row."""
    if not 1 <= count <= MAX_THROWS:
        raise AppError(f"the number of training throws must be 1 to {MAX_THROWS}, got {count}")
    (x0, x1), (z0, z1) = area.x, area.z
    wx, wz = max(x1 - x0, 1e-9), max(z1 - z0, 1e-9)
    nx, nz = _grid_shape(count, wx / wz)
    X, Z = np.meshgrid(np.linspace(x0, x1, nx), np.linspace(z0, z1, nz), indexing="ij")
    grid = np.column_stack([X.ravel(), Z.ravel()])
    if len(grid) == count:
        return grid
    scaled = (grid - (x0, z0)) / (wx, wz)  # distances in the area's own units: both axes count alike
    corners = [int(np.argmin(np.linalg.norm(scaled - c, axis=1))) for c in ((0, 0), (1, 1), (1, 0), (0, 1))]
    taken: list[int] = list(dict.fromkeys(corners))[:count]
    gap = np.min(np.linalg.norm(scaled[:, None] - scaled[taken][None], axis=2), axis=1)
    while len(taken) < count:
        k = int(np.argmax(gap))
        taken.append(k)
        gap = np.minimum(gap, np.linalg.norm(scaled - scaled[k], axis=1))
    return grid[sorted(taken)]


def _grid_shape(count: int, aspect: float) -> tuple[int, int]:
    """(nx, nz) for `training_targets_for`: fewest extra points, then closest to `aspect` = wx / wz."""
    best: tuple[float, float, int, int] | None = None
    for nz in range(1, count + 1):
        nx = math.ceil(count / nz)
        off = abs(math.log(nx / nz) - math.log(aspect))
        if off > math.log(2.5) and count > 2:
            continue
        key = (float(nx * nz - count), off, nx, nz)
        best = key if best is None or key < best else best
    if best is None:  # a very elongated area: one row along it
        return (count, 1) if aspect >= 1 else (1, count)
    return best[2], best[3]


def reachable_area(arm: ArmModel, area: Area, ball: Ball | None = None) -> tuple[Area, list[str]]:
    """`area` bounded by the arm's reach at the velocity margin: the simulated operator's throws
    (`throwing.operator.solve_throw`, capped at 0.9 x 95 % of each joint's speed limit) must reach
    its four corners; where a corner is out of reach, its x is moved towards the other (bisection,
    to REACH_TOLERANCE_M). Returns the area and one line per change; AppError when nothing of the
    area is within reach."""
    (x0, x1), (z0, z1) = sorted(area.x), sorted(area.z)
    notes: list[str] = []

    def reaches(x: float, z: float) -> bool:
        try:
            solve_throw(arm, (x, z), ball=ball)
            return True
        except UnreachableTargetError:
            return False

    far, near = x1, x0
    for z in (z1, z0):  # the high edge limits the reach first
        if not reaches(far, z):
            lo, hi = near, far
            if not reaches(lo, z):
                raise AppError(
                    f"the area {area} is beyond the arm's reach at the velocity margin at z {z:.2f} m: bring it closer"
                )
            while hi - lo > REACH_TOLERANCE_M:
                mid = 0.5 * (lo + hi)
                lo, hi = (mid, hi) if reaches(mid, z) else (lo, mid)
            notes.append(f"x max {far:.2f} -> {lo:.2f} m: the arm's reach at z {z:.2f} m at the velocity margin")
            far = lo
        if not reaches(near, z):
            lo, hi = near, far
            while hi - lo > REACH_TOLERANCE_M:
                mid = 0.5 * (lo + hi)
                lo, hi = (lo, mid) if reaches(mid, z) else (mid, hi)
            notes.append(f"x min {near:.2f} -> {hi:.2f} m: closer is out of the arm's reach at z {z:.2f} m")
            near = hi
    if far - near < REACH_TOLERANCE_M:
        raise AppError(f"the area {area} leaves no width within the arm's reach at the velocity margin")
    return Area((near, far), (z0, z1)), notes


def _finite(values: Any, n: int, what: str) -> NDArray[np.float64]:
    a = np.asarray(values, dtype=float).reshape(-1)
    if a.shape != (n,) or not np.isfinite(a).all():
        raise ValueError(f"{what} must be {n} finite numbers, got {values!r}")
    return a
