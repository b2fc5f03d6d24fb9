"""The session's library that keeps learning: measured throws join it, its file keeps the history.

`LearningLibrary` wraps a `throwing.online.OnlineLibrary` (the regression, the retirement rules,
the trained area) with what the app adds: where the library lives on disk and the one step that
joins an executed throw (`join`): its planned parameters and its target, labelled by the landing
the rig measured (a simulated world's own measurement, or the operator's *Measure landing*) in the
throw's plane, and by how far beside that plane it came down (its across offset, which the
library's sideways term learns: `throwing.lateral`); then
the library is written back atomically (`library_file.save_library`), its `meta["learning"]`
holding the join numbers and every update (time, throw, source, what was retired), so a restart
resumes the same regression. With no path (the shipped library) the learning stays in memory:
the package's file is never written.

Only a measured, finite landing joins; a failed throw or a throw whose landing was not measured
does not, and a late release (`ThrowExecution.release_late_s`: the hand opened beyond
`release_timing.RELEASE_LATE_BOUND_S` after its time, so the ball did not fly the planned throw)
and a throw lost in the wind-up (its ball left the hand before the release, `hand_watch`) are
refused (`NotJoined`, saying why). Each join's summary (`JoinSummary.to_dict`) goes into the
throw's record, and so into `wiithrow throw --json` and a recording's `/throws`.
"""

from __future__ import annotations

import datetime as _dt
import os
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from wiithrow.app.errors import AppError
from wiithrow.app.throws.library_file import save_library
from wiithrow.app.throws.release_timing import RELEASE_LATE_BOUND_S
from wiithrow.throwing import ThrowLibrary, ThrowParameters, TrainedThrow
from wiithrow.throwing.online import OnlineLibrary, Update
from wiithrow.vision.errors import VisionError


@dataclass(frozen=True)
class JoinSummary:
    """What one join did: the throw's join number, its `source`, the library's size after it, the
    landings (x, z) of the throws retired and why, the refit's wall time (ms), where it was saved
    (or why it could not be: the throw is kept in the record and in memory all the same), and the
    learned across offset at the throw's landing after it (m: what the next throw there aims away)."""

    joined: int
    source: str
    size: int
    retired: tuple[tuple[tuple[float, float], str], ...]
    refit_ms: float
    saved_to: str | None
    save_error: str | None = None  # why the file could not be written (one line); None: saved or no file
    across_m: float | None = None

    def to_dict(self) -> dict[str, object]:
        return {
            "joined": self.joined,
            "source": self.source,
            "library_size": self.size,
            "retired": [{"landing_throw_plane_link1_m": list(xz), "reason": why} for xz, why in self.retired],
            "refit_ms": self.refit_ms,
            "saved_to": self.saved_to,
            "save_error": self.save_error,
            "learned_across_offset_m": self.across_m,
        }


class NotJoined(AppError):
    """A throw the library refuses to join (one line: why)."""


class LearningLibrary:
    """A throw library that measured throws join (module docstring); `path`: its file, or None."""

    def __init__(self, library: ThrowLibrary, path: str | os.PathLike[str] | None = None) -> None:
        self.online = OnlineLibrary.start(library)
        self.path = Path(path) if path is not None else None

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
        across_m: float | None = None,
    ) -> JoinSummary | None:
        """The throw `params` aimed at `target_xz`, which landed at `measured_xz` (its plane, m)
        `across_m` beside it (m, + toward link1's +y; None: not measured), joins the library (None
        when the landing is not finite: nothing joins); the file is rewritten.
        `release_late_s`: the throw's late release (`ThrowExecution.release_late_s`; None: on
        time); a late one is refused (`NotJoined`): its landing is not the planned throw's; so is a
        throw whose ball left the hand before the release (`ball_lost`: lost in the wind-up)."""
        if ball_lost:
            raise NotJoined("its ball left the hand in the wind-up, before the release: nothing flew the planned throw")
        if release_late_s is not None:
            raise NotJoined(
                f"its release was late ({1e3 * release_late_s:.0f} ms after its time, bound "
                f"{1e3 * RELEASE_LATE_BOUND_S:.0f} ms): the ball did not fly the planned throw"
            )
        if not (np.isfinite(measured_xz).all() and np.isfinite(target_xz).all()):
            return None
        across = float(across_m) if across_m is not None and np.isfinite(across_m) else None
        throw = TrainedThrow(np.asarray(target_xz, float), params, np.asarray(measured_xz, float), across)
        start = time.perf_counter()
        update: Update = self.online.add(throw, time=_dt.datetime.now().isoformat(timespec="seconds"), source=source)
        refit_ms = 1e3 * (time.perf_counter() - start)
        saved, error = None, None
        if self.path is not None:
            try:  # the throw has joined in memory whatever the disk says; the next save writes it too
                saved = str(save_library(self.path, self.online.library))
            except (OSError, VisionError) as exc:
                error = f"the throw library could not be saved to {self.path}: {exc}"
        return JoinSummary(
            update.joined,
            source,
            len(self.online),
            tuple(((float(t.landing[0]), float(t.landing[1])), why) for t, why in update.retired),
            refit_ms,
            saved,
            error,
            self.online.across(throw.landing),
        )
