"""The session's library that keeps learning: credible measured throws join it, each update a version.

`LearningLibrary` wraps a `throwing.online.OnlineLibrary` (the regression, the retirement rules,
the trained area) with what the app adds: the one step that joins an executed throw (`join`): its
planned parameters and its target, labelled by the landing the rig measured (a simulated world's
own measurement, or the operator's *Measure landing*) in the throw's plane, and by how far beside
that plane it came down (its across offset, which the library's sideways term learns:
`throwing.lateral`), and where the update goes: with a library folder
(`library_store.LibraryStore`) every update is a new version, whose parent is the version the throw
joined (the one in use); without one the learning stays in memory (a library given as a file, or
the shipped one, is never written).

**A throw joins only when its landing is credible** (else `NotJoined`, saying why, and nothing
changes):

* the ball left the hand at the release: not a late release (`ThrowExecution.release_late_s`: the
  hand opened beyond `release_timing.RELEASE_LATE_BOUND_S` after its time) and not lost in the
  wind-up (its ball left the hand before the release, `hand_watch`);
* the landing was seen: a finite measurement (an unmeasured one does not join yet: `join` returns
  None, and the operator's *Measure landing* joins it later);
* it lies within `landing_checks.LANDING_PREDICTION_BOUND_M` (0.25 m) of the throw's predicted
  landing (the planner's model's landing of the planned throw), the bound a training landing is
  held to: a landing a metre off is a marker put elsewhere, not a drift.

**An update that makes the library worse is kept but not used.** Before and after the throw joins,
the held-out error of the `UPDATE_HELDOUT_THROWS` throws nearest it is measured the same way
(`throwing.online_heldout`: closed form, fixed hyperparameters); when the update's mean is worse
than its parent's by more than `WORSE_UPDATE_M`, the update is written as a version marked not used
(with both figures and the reason), the library in use stays the parent, and the next throw joins
the parent.

Each join's summary (`JoinSummary.to_dict`) goes into the throw's record, and so into `wiithrow
throw --json`, a recording's `/throws` and the dashboard's Library folder (what the learning did).
"""

from __future__ import annotations

import copy
import datetime as _dt
import time
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from wiithrow.app.errors import AppError
from wiithrow.app.throws.landing_checks import LANDING_PREDICTION_BOUND_M
from wiithrow.app.throws.library_store import Heldout, LibraryStore, VersionInfo
from wiithrow.app.throws.release_timing import RELEASE_LATE_BOUND_S
from wiithrow.robot import ArmModel
from wiithrow.throwing import ThrowLibrary, ThrowParameters, TrainedThrow
from wiithrow.throwing.online import META_KEY, OnlineLibrary, Update
from wiithrow.throwing.online_heldout import OwnLandings, heldout_errors
from wiithrow.vision.errors import VisionError

#: How many throws around a joining throw judge its update (module docstring): the paper's training
#: size, so that in a 25-throw library it is the whole library and in one of 200 the update's
#: neighbourhood (a bad throw's harm is local; the whole library's mean would hide it).
UPDATE_HELDOUT_THROWS = 25
#: An update whose held-out mean is worse than its parent's by more than this (m) is not used. The
#: updates of credible throws move it by less: at most +0.6 mm over 10 throws in each simulated
#: world, and +0.7 mm over 10 throws of a 15 ms release drift the learning must follow (kinematic
#: world, seed 0); a throw labelled 5 cm off moves it by +4.2 mm, 10 cm off +7.7 mm, 20 cm +14 mm.
WORSE_UPDATE_M = 0.003


@dataclass(frozen=True)
class JoinSummary:
    """What one join did: the throw's join number, its `source`, the library's size after it, the
    landings (x, z) of the throws retired and why, the refit's wall time (ms), the held-out errors
    (m) of the update and of its parent near the throw, whether the update is `used` (else
    `not_used` says why), the version it was written as (or why it could not be: the throw is kept
    in the record and in memory all the same), and the learned across offset at the throw's landing
    after it (m: what the next throw there aims away)."""

    joined: int
    source: str
    size: int
    retired: tuple[tuple[tuple[float, float], str], ...]
    refit_ms: float
    heldout_m: float
    parent_heldout_m: float
    used: bool
    not_used: str | None = None
    version: int | None = None
    saved_to: str | None = None
    save_error: str | None = None  # why the version could not be written (one line); None: saved or no folder
    across_m: float | None = None

    def to_dict(self) -> dict[str, object]:
        return {
            "joined": self.joined,
            "source": self.source,
            "library_size": self.size,
            "retired": [{"landing_throw_plane_link1_m": list(xz), "reason": why} for xz, why in self.retired],
            "refit_ms": self.refit_ms,
            "heldout_m": self.heldout_m,
            "parent_heldout_m": self.parent_heldout_m,
            "used": self.used,
            "not_used": self.not_used,
            "version": self.version,
            "saved_to": self.saved_to,
            "save_error": self.save_error,
            "learned_across_offset_m": self.across_m,
        }


class NotJoined(AppError):
    """A throw the library refuses to join (one line: why)."""


class LearningLibrary:
    """A throw library that credible measured throws join (module docstring).

    `library`: the library in use; `arm`: the arm's model (the held-out flights); `store` and
    `version`: its library folder and its version there (None: not in the folder yet, written as
    an import, `origin`, before the first update); `calibration`: the fingerprint of the rig's
    calibration now (what the versions record)."""

    def __init__(
        self,
        library: ThrowLibrary,
        arm: ArmModel,
        *,
        store: LibraryStore | None = None,
        version: VersionInfo | None = None,
        calibration: Callable[[], str | None] = lambda: None,
        origin: str = "the library in use when the learning started",
    ) -> None:
        self.online = OnlineLibrary.start(library)
        self.arm, self.store, self.version = arm, store, version
        self.calibration, self.origin = calibration, origin
        self._own = OwnLandings()  # each kept throw's own landing, flown once

    @property
    def library(self) -> ThrowLibrary:
        """The throws kept now, with the learning's state and history (`OnlineLibrary.library`)."""
        return self.online.library

    def join(
        self,
        params: ThrowParameters,
        target_xz: NDArray[np.float64],
        measured_xz: NDArray[np.float64],
        source: str,
        *,
        release_late_s: float | None,
        ball_lost: bool = False,
        predicted_xz: NDArray[np.float64] | None = None,
        across_m: float | None = None,
    ) -> JoinSummary | None:
        """The throw `params` aimed at `target_xz`, which landed at `measured_xz` (its plane, m; its
        model's landing `predicted_xz`) `across_m` beside it (m, + toward link1's +y; None: not
        measured), joins the library if credible (module docstring: else `NotJoined`), and the update
        is used unless it is worse; None when the landing is not finite (not seen: nothing joins)."""
        if ball_lost:
            raise NotJoined("its ball left the hand in the wind-up, before the release: nothing flew the planned throw")
        if release_late_s is not None:
            raise NotJoined(
                f"its release was late ({1e3 * release_late_s:.0f} ms after its time, bound "
                f"{1e3 * RELEASE_LATE_BOUND_S:.0f} ms): the ball did not fly the planned throw"
            )
        if not (np.isfinite(measured_xz).all() and np.isfinite(target_xz).all()):
            return None
        landing = np.asarray(measured_xz, float)
        across = float(across_m) if across_m is not None and np.isfinite(across_m) else None
        if predicted_xz is not None and np.isfinite(predicted_xz).all():
            # the distance on the surface: in the plane and beside it (the model predicts no offset)
            off = float(np.hypot(np.linalg.norm(landing - np.asarray(predicted_xz, float)), across or 0.0))
            if not off <= LANDING_PREDICTION_BOUND_M:
                raise NotJoined(
                    f"its measured landing (x {landing[0]:.3f}, z {landing[1]:.3f} m) is {off:.2f} m from its predicted "
                    f"landing (at most {LANDING_PREDICTION_BOUND_M:g} m): not a landing its throw could make (a marker put "
                    "elsewhere?)"
                )
        throw = TrainedThrow(np.asarray(target_xz, float), params, landing, across)
        first = self.online.library if self.store is not None and self.version is None else None
        parent = float(np.mean(self._near(self.online, landing)))
        start = time.perf_counter()
        candidate = _fork(self.online)
        update: Update = candidate.add(throw, time=_dt.datetime.now().isoformat(timespec="seconds"), source=source)
        refit_ms = 1e3 * (time.perf_counter() - start)
        errors = self._near(candidate, landing)
        heldout = float(np.mean(errors))
        used = heldout <= parent + WORSE_UPDATE_M
        not_used = None
        if used:  # in place: the planner serving `online` serves the update
            self.online.__dict__.update(candidate.__dict__)
            self._own.keep(self.online.throws)
        else:
            not_used = (
                f"its held-out error near the throw is worse than its parent's ({1e3 * heldout:.1f} mm against "
                f"{1e3 * parent:.1f} mm, at most {1e3 * WORSE_UPDATE_M:.0f} mm worse): kept as a version, not used"
            )
        summary = JoinSummary(
            update.joined,
            source,
            len(candidate),
            tuple(((float(t.landing[0]), float(t.landing[1])), why) for t, why in update.retired),
            refit_ms,
            heldout,
            parent,
            used,
            not_used,
            across_m=self.online.across(throw.landing),
        )
        return self._write(candidate.library, summary, Heldout.of(errors, "fixed, near the update"), first)

    def _near(self, online: OnlineLibrary, landing: NDArray[np.float64]) -> NDArray[np.float64]:
        """The held-out errors (m) of `online`'s `UPDATE_HELDOUT_THROWS` throws nearest `landing`."""
        return heldout_errors(online, self.arm, near=landing, count=UPDATE_HELDOUT_THROWS, own=self._own)

    def _write(
        self, library: ThrowLibrary, summary: JoinSummary, heldout: Heldout, first: ThrowLibrary | None
    ) -> JoinSummary:
        """The update as a version of the library folder (none: the summary as it is); `first`: the
        library the learning started from, written first when it is not a version yet."""
        if self.store is None:
            return summary
        try:  # the throw has joined in memory whatever the disk says
            if self.version is None:  # the library it started from, first: the update's parent
                self.version = self.store.add(
                    version_library(first if first is not None else library), parent=None, by="command",
                    how="import", note=self.origin, calibration=None, heldout=None, use=True,
                )  # fmt: skip
            info = self.store.add(
                version_library(library),
                parent=self.version.id,
                by="learning",
                how="learning",
                note=f"throw {summary.joined} joined ({summary.source})",
                calibration=self.calibration(),
                heldout=heldout,
                learning={
                    "joined": summary.joined,
                    "source": summary.source,
                    "retired": len(summary.retired),
                    "parent_heldout_m": summary.parent_heldout_m,
                    "used": summary.used,
                    "not_used": summary.not_used,
                },
                use=summary.used,
            )
        except (OSError, VisionError, AppError) as exc:
            return _replace(summary, save_error=f"the update could not be saved to {self.store.folder}: {exc}")
        if summary.used:
            self.version = info
        return _replace(summary, version=info.id, saved_to=str(self.store.path(info.id)))


def _fork(online: OnlineLibrary) -> OnlineLibrary:
    """A copy of `online` to add a throw to, its arrays and lists its own; the frozen throws and
    updates it holds are shared (a deep copy of a history of thousands of updates cost more than
    the refit)."""
    memo: dict[int, object] = {id(u): u for u in online.history}
    memo.update({id(t): t for t in online.throws})
    return copy.deepcopy(online, memo)


def version_library(library: ThrowLibrary) -> ThrowLibrary:
    """`library` as a version keeps it: its learning history cut to the update that made it (the
    versions' chain is the history; `history_dropped` counts the rest)."""
    state = library.meta.get(META_KEY)
    if not isinstance(state, dict) or len(state.get("history", [])) <= 1:
        return library
    history = state["history"]
    kept = {
        **state,
        "history": history[-1:],
        "history_dropped": int(state.get("history_dropped", 0)) + len(history) - 1,
    }
    return ThrowLibrary(library.arm, library.shape, library.ball, library.throws, {**library.meta, META_KEY: kept})


def _replace(summary: JoinSummary, **changes: object) -> JoinSummary:
    from dataclasses import replace

    return replace(summary, **changes)  # type: ignore[arg-type]
