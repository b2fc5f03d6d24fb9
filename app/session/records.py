"""What the session hands to its views: a validated throw to preview, the record of an executed
throw, and the session's whole state as one immutable snapshot (`SessionSnapshot`).

Positions are in m, in the link1 throw plane (x, z) unless a name says `base`; angles in rad.
A throw's error is its measured landing against its measured target in 3D, along / across /
height and the total on the landing surface (`ThrowRecord.error`; the one definition,
`wiithrow.throwing.landing_error`); in simulation the true one beside it (`true_error`).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from wiithrow.app.alignment import AlignmentResult
from wiithrow.app.calibration.robot import RobotCalibration
from wiithrow.app.calibration.wand import WandRun
from wiithrow.app.calibration.wand_capture import CaptureProgress
from wiithrow.app.session.operations import Operation
from wiithrow.app.throws.execution import ThrowExecution
from wiithrow.app.throws.library_compare import LibraryChoice
from wiithrow.app.throws.training_run import TrainingOutcome, TrainingRun
from wiithrow.app.worlds import RigWorld
from wiithrow.throwing import ValidatedThrow, flight_path
from wiithrow.throwing.landing_error import LandingError, landing_error
from wiithrow.throwing.throw_plane import turned

#: Distance (m) the target may be moved after an alignment before it no longer holds (Preview
#: asks for Track target again).
TARGET_MOVED_M = 0.02


def _xz(point: NDArray[np.float64]) -> dict[str, float]:
    """A point of the throw plane as JSON: {"x": distance from the joint-1 axis, "z": height}."""
    return {"x": float(point[0]), "z": float(point[1])}


def _in_plane_base(target_xz: NDArray[np.float64], q1: float) -> NDArray[np.float64]:
    """The point (x, z) of the throw plane at joint-1 angle `q1` in `base` (x, 0, z turned by q1)."""
    return turned(np.array([target_xz[0], 0.0, target_xz[1]], dtype=float), q1)


@dataclass(frozen=True)
class ThrowPreview:
    """A validated throw ready to execute, and what the operator should see before saying yes."""

    id: int
    throw: ValidatedThrow
    target_xz: NDArray[np.float64]  # where the throw is planned to land in its plane (link1 x, z), m
    q1: float  # joint-1 angle, rad
    predicted_xz: NDArray[np.float64]
    predicted_base: NDArray[np.float64]
    arc_base: NDArray[np.float64] = field(repr=False)  # (N, 3) predicted ball path
    arc_times: NDArray[np.float64] = field(repr=False)  # (N,) s after the release, one per arc point
    peak_speed: NDArray[np.float64] = field(repr=False)  # (nq,) rad/s
    velocity_limit: NDArray[np.float64] = field(repr=False)
    # the target as the rig measured it, in base (m): what the throw's error is taken against
    target_measured_base: NDArray[np.float64] = field(default_factory=lambda: np.full(3, np.nan), repr=False)
    # the learned across offset (m) joint 1 was turned to aim away (`throwing.lateral`; 0: none)
    across_m: float = 0.0

    @property
    def duration_s(self) -> float:
        return float(self.throw.trajectory.duration)

    @property
    def speed_ratio(self) -> NDArray[np.float64]:
        """Peak joint speed over its limit, per joint (<= 1)."""
        return self.peak_speed / self.velocity_limit

    def to_dict(self, ball_offset_m: float, *, trajectory: bool = True) -> dict[str, Any]:
        """The plan as JSON (`wiithrow throw --dry-run --json`), checkable by anyone; `trajectory`:
        with the joint positions at every control step (about 200 KB for a 2 s throw)."""
        traj = self.throw.trajectory
        release = self.throw.release
        plan = {
            "joint1_rad": self.q1,
            "target_throw_plane_link1_m": _xz(self.target_xz),
            "release_time_s": float(self.throw.release_time),
            "release_position_base_m": np.asarray(release.position).tolist(),
            "release_velocity_base_m_s": np.asarray(release.velocity).tolist(),
            "ball_offset_from_flange_m": [0.0, 0.0, ball_offset_m],
            "predicted_landing_base_m": self.predicted_base.tolist(),
            "predicted_landing_throw_plane_link1_m": _xz(self.predicted_xz),
            "target_measured_base_m": self.target_measured_base.tolist(),
            "learned_across_offset_m": self.across_m,
            "duration_s": self.duration_s,
            "peak_joint_speed_rad_s": self.peak_speed.tolist(),
            "joint_velocity_limit_rad_s": self.velocity_limit.tolist(),
        }
        if trajectory:
            plan["trajectory"] = {
                "dt_s": float(traj.dt),
                "times_s": traj.times.tolist(),
                "positions_rad": traj.positions.tolist(),
            }
        return plan


def preview_of(
    world: RigWorld,
    preview_id: int,
    throw: ValidatedThrow,
    target_xz: NDArray[np.float64],
    q1: float,
    *,
    target_measured_base: NDArray[np.float64] | None = None,
    across_m: float = 0.0,
) -> ThrowPreview:
    """The preview of a validated `throw` at `target_xz` in `world` (its ball's predicted arc, the
    peak joint speeds against the limits): what the operator sees before saying yes.
    `target_measured_base`: the target as measured, in base (default: `target_xz` in the plane at
    `q1`, a training target); `across_m`: the learned across offset aimed away."""
    release = throw.release
    target = target_measured_base
    if target is None:
        target = _in_plane_base(np.asarray(target_xz, float), q1)
    arc_times, arc = flight_path(release.position, release.velocity, throw.landing_height, world.ball())
    return ThrowPreview(
        preview_id,
        throw,
        np.asarray(target_xz, float),
        float(q1),
        np.asarray(throw.predicted.xz, float),
        np.asarray(throw.predicted.landing.position, float),
        arc,
        arc_times,
        np.abs(throw.trajectory.velocities).max(axis=0),
        world.arm_model.velocity_limit.copy(),
        np.asarray(target, dtype=float).reshape(3).copy(),
        float(across_m),
    )


@dataclass(frozen=True)
class ThrowRecord:
    """One executed throw, for the table of last throws (m, link1 throw plane unless named)."""

    index: int
    wall_time: str
    target_xz: NDArray[np.float64]  # where the throw was planned to land in its plane (the target, measured)
    landing_xz: NDArray[np.float64]  # as the rig measured the landing marker, in the throw's plane
    predicted_xz: NDArray[np.float64]
    q1: float
    execution: ThrowExecution = field(repr=False)
    target_base: NDArray[np.float64] | None = None  # the true target (simulation only)
    failure: str | None = None  # why the throw ended early (one line); None: it ran to its end
    # what joining the learning library did (`app.throws.learning.JoinSummary.to_dict`); None: it did not join
    learned: dict[str, Any] | None = None
    # lost in the wind-up: the ball left the hand before the release (`safe_stop.ThrowFault.ball_lost`),
    # this long before it (s; None: unknown)
    ball_lost: bool = False
    ball_lost_before_s: float | None = None
    # the target as the rig measured it, in base (m; None: taken as `target_xz` in the plane at `q1`)
    target_measured_base: NDArray[np.float64] | None = None
    # the landing measured anew with *Measure landing* (`Session.measure_landing`): the error is that measurement's
    measured_again: bool = False

    def to_dict(self) -> dict[str, Any]:
        """The throw's outcome as JSON (`wiithrow throw --json`'s `result`), frames in the keys."""
        return {
            "failure": self.failure,
            "ball_lost_in_wind_up": self.ball_lost,
            "ball_lost_before_release_s": self.ball_lost_before_s,
            "release_late_s": self.execution.release_late_s,
            "learning": self.learned,
            "target_measured_throw_plane_link1_m": _xz(self.target_xz),
            "landing_measured_throw_plane_link1_m": _xz(self.landing_xz),
            "predicted_landing_throw_plane_link1_m": _xz(self.predicted_xz),
            "landing_measured_across_throw_plane_m": float(self.execution.measured_plane[1]),
            "target_measured_base_m": self.target_measured.tolist(),
            "landing_measured_base_m": self.execution.measured_base.tolist(),
            "error": self.error.to_dict(),
            "true_error": None if self.true_error is None else self.true_error.to_dict(),
            "error_m": self.error_m,
            "true_error_m": self.true_error_m,
            "landing_true_base_m": self.execution.landing_base.tolist(),
        }

    @property
    def target_measured(self) -> NDArray[np.float64]:
        """The target as the rig measured it, in base (m)."""
        if self.target_measured_base is not None:
            return self.target_measured_base
        return _in_plane_base(self.target_xz, self.q1)

    @property
    def error(self) -> LandingError:
        """The measured landing against the measured target in 3D (`throwing.landing_error`): what
        the operator sees; NaN until the landing is measured."""
        return landing_error(self.execution.measured_base, self.target_measured)

    @property
    def error_m(self) -> float:
        """The error's total (m): the distance on the landing surface, along and across."""
        return self.error.total_m

    @property
    def true_error(self) -> LandingError | None:
        """Simulation only: the true landing against the true target, split the same way."""
        if self.target_base is None:
            return None
        return landing_error(self.execution.landing_base, self.target_base)

    @property
    def true_error_m(self) -> float | None:
        """Simulation only: the true error's total (m), the distance on the surface."""
        true = self.true_error
        return None if true is None else true.total_m


def failed_throw_record(
    index: int,
    wall_time: str,
    preview: ThrowPreview,
    failure: str,
    released_at: float | None,
    target_base: NDArray[np.float64] | None,
    *,
    ball_lost: bool = False,
    ball_lost_before_s: float | None = None,
) -> ThrowRecord:
    """The record of a throw that ended early (`failure`, one line): nothing measured (NaN), the
    planned release, `released_at` when the hand was told to open (NaN: never); `ball_lost`: it
    was lost in the wind-up, `ball_lost_before_s` (s) before the release."""
    throw, nan3 = preview.throw, np.full(3, np.nan)
    execution = ThrowExecution(
        throw.release,
        nan3,
        nan3,
        nan3,
        np.zeros((0, 3)),
        np.zeros(0),
        preview.q1,
        float("nan") if released_at is None else float(released_at),
    )
    return ThrowRecord(
        index,
        wall_time,
        preview.target_xz,
        np.full(2, np.nan),
        preview.predicted_xz,
        preview.q1,
        execution,
        target_base,
        failure,
        ball_lost=ball_lost,
        ball_lost_before_s=ball_lost_before_s,
        target_measured_base=preview.target_measured_base,
    )


@dataclass(frozen=True)
class SessionSnapshot:
    """The operator's session's whole state, immutable (`Session.snapshot()`; the session swaps
    it for a `dataclasses.replace`d copy under its lock at every change, and nothing else writes it).

    `revision` grows by one with every change (and every event the session sends): a view that
    saw revision r has nothing new to draw while it stays r. `operation` is the one running (None:
    idle); `progress` its (message, fraction). `message` is the last thing the operator should read
    (an alignment's end, "stopped by the operator", what to do after a throw on hardware).
    `target_base` is where the target was last put from here (`Session.set_target`; NaN: unknown,
    a real target), `aligned_target_base` where it was when the last alignment ran: the alignment
    no longer holds once they are more than TARGET_MOVED_M apart (`target_moved`), a comparison
    of two placements in one frame, never of a measurement with the simulation's truth.
    """

    revision: int = 0
    operation: Operation | None = None
    progress: tuple[str, float] = ("", 0.0)
    message: str = ""
    calibration: RobotCalibration | None = None  # the last robot calibration
    alignment: AlignmentResult | None = None
    preview: ThrowPreview | None = None
    history: tuple[ThrowRecord, ...] = ()
    wand: WandRun | None = None  # the last wand calibration
    wand_progress: CaptureProgress | None = None  # the wand capture under way (or the last one)
    target_base: NDArray[np.float64] = field(default_factory=lambda: np.full(3, np.nan), repr=False)
    aligned_target_base: NDArray[np.float64] = field(default_factory=lambda: np.full(3, np.nan), repr=False)
    previews_made: int = 0
    training: TrainingRun | None = None  # the training run under way (`wiithrow.app.session.training`)
    training_preview: ThrowPreview | None = None  # the current training throw, validated, not yet thrown
    training_outcome: TrainingOutcome | None = None  # the last finished run
    library_choice: LibraryChoice | None = None  # its library, waiting for the operator's choice
    learning: bool = True  # measured throws join the library (`Session.set_learning`)

    @property
    def busy(self) -> bool:
        """True while an operation runs."""
        return self.operation is not None

    @property
    def last_throw(self) -> ThrowRecord | None:
        return self.history[-1] if self.history else None

    @property
    def target_moved(self) -> bool:
        """The target was moved by more than TARGET_MOVED_M since the last alignment."""
        if self.alignment is None:
            return False
        moved = self.target_base - self.aligned_target_base
        return bool(np.isfinite(moved).all() and np.linalg.norm(moved) > TARGET_MOVED_M)
