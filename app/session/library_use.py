"""The session's throw library: which one is in use, where its versions live, and the choices an
operator makes about it.

Owns `LibraryOperations`, the part of `Session` that keeps the library in use: the one the session
was given (a command's `--library`, imported into the library folder as a version), else the
folder's version in use (`library_store.LibraryStore`), else the library shipped with the package;
the learning library made from it (`wiithrow.app.throws.learning`: its updates are versions of the
folder); the planner. And two operations:

* `use_version(n)`: go back (or forward) to version n of the library folder (`Operation.LIBRARY_USE`);
* `choose_trained_library(use)`: the operator's choice after *Finish training*, use the new library
  or keep the one in use (`Operation.LIBRARY_CHOOSE`), refused while no trained library waits.

Whenever a library is put in use, and before a throw is planned with it, its versions' record of
the calibration its labels were measured with is compared with the rig's calibration now: another
one is said in one line (the session's message), once per pair.
"""

from __future__ import annotations

import contextlib
from typing import Any

from wiithrow.app.errors import AppError
from wiithrow.app.session.operations import Event, Operation
from wiithrow.app.session.records import SessionSnapshot
from wiithrow.app.throws.learning import LearningLibrary
from wiithrow.app.throws.library_file import load_library
from wiithrow.app.throws.library_store import LibraryStore, VersionInfo
from wiithrow.app.worlds import RigWorld
from wiithrow.throwing import AnalyticPlanner, ThrowLibrary, ThrowPlanner
from wiithrow.throwing.errors import ThrowingError
from wiithrow.vision.stereo_calibration import calibration_fingerprint


def calibration_note(version: VersionInfo | None, fingerprint: str | None) -> str:
    """One line when `version` was trained with another calibration than `fingerprint` ("" else)."""
    if version is None or version.calibration is None or fingerprint is None or version.calibration == fingerprint:
        return ""
    return (
        f"library version {version.id} was trained with calibration {version.calibration} and the rig now uses "
        f"{fingerprint}: its labels were measured by another calibration (train again if the rig moved)"
    )


class LibraryOperations:
    """The library steps of `Session` (module docstring). `Session` provides the state and the
    operation frame these methods use."""

    world: RigWorld
    margin_m: float
    _library: ThrowLibrary | None
    _version: VersionInfo | None
    _store: LibraryStore | None
    _learning: LearningLibrary | None
    _planner: ThrowPlanner | AnalyticPlanner | None
    _analytic: bool
    _noted: set[tuple[int, str]]
    _library_given: bool

    # -- provided by Session ------------------------------------------------------------------------

    def snapshot(self) -> SessionSnapshot:
        raise NotImplementedError

    def _operation(
        self, op: Operation, *, instead: dict[str, str] | None = None
    ) -> contextlib.AbstractContextManager[None]:
        raise NotImplementedError

    def _update(self, event: Event, **changes: Any) -> SessionSnapshot:
        raise NotImplementedError

    def tell(self, message: str) -> None:
        raise NotImplementedError

    # -- the library in use ---------------------------------------------------------------------------

    @property
    def library(self) -> ThrowLibrary:
        """The trained throws in use: the one given, else the library folder's version in use, else
        the shipped library of the simulated PA-10."""
        if self._library is None:
            found = self._store.in_use() if self._store is not None else None
            if found is not None:
                self._version, library = found
            else:
                library = load_library()
            library.require_arm(self.world.arm_model.name)
            self._library = library
        return self._library

    @property
    def library_version(self) -> VersionInfo | None:
        """The library folder's version in use (None: a library that is not one, e.g. the shipped one)."""
        _ = self.library
        if self._learning is not None:
            return self._learning.version
        return self._version

    @property
    def library_store(self) -> LibraryStore | None:
        """The library folder (None: the session keeps no versions)."""
        return self._store

    def current_library(self) -> ThrowLibrary:
        """The library the planner serves now: the learning's state once a throw joined."""
        return self._learning.library if self._learning is not None else self.library

    def comparable_library(self) -> tuple[ThrowLibrary | None, VersionInfo | None]:
        """What a new library is compared with: the library the planner serves now and its version,
        or (None, None) when there is none for this arm yet (a new arm: the shipped library is the
        PA-10's)."""
        try:
            return self.current_library(), self.library_version
        except ThrowingError:
            return None, None

    def use_library(self, library: ThrowLibrary) -> None:
        """Throw with these trained throws from now on (not a version of the folder)."""
        library.require_arm(self.world.arm_model.name)
        with self._operation(Operation.CHANGE_PLANNER):
            self._put_in_use(library, None)

    def use_version(self, version: int, *, by: str = "operator") -> VersionInfo:
        """Put version `version` of the library folder in use (`Operation.LIBRARY_USE`); AppError
        without a folder, for an unknown or broken version or one of another arm."""
        with self._operation(Operation.LIBRARY_USE):
            if self._store is None:
                raise AppError("no library folder: this session keeps no versions of its library")
            info, library = self._store.load(version)
            library.require_arm(self.world.arm_model.name)
            self._store.use(version, by)
            self._put_in_use(
                library, info, message=f"library version {version} in use ({info.how}, {info.throws} throws)"
            )
        return info

    def choose_trained_library(self, use: bool, *, by: str = "operator") -> str:
        """After *Finish training*: put the new library in use (`use`), or keep the one in use;
        returns what was done (one line, also the session's message)."""
        with self._operation(Operation.LIBRARY_CHOOSE):
            choice = self.snapshot().library_choice
            assert choice is not None  # refusal(LIBRARY_CHOOSE) holds it
            return self._settle_choice(use, by)

    def _settle_choice(self, use: bool, by: str) -> str:
        """The choice waiting in the snapshot, made (inside an operation)."""
        state = self.snapshot()
        choice, outcome = state.library_choice, state.training_outcome
        assert choice is not None
        label = f"version {choice.version}" if choice.version is not None else "the trained library"
        if use:
            info = None
            if self._store is not None and choice.version is not None:
                info = self._store.use(choice.version, by)
            line = f"{label} in use: {choice.comparison.new.throws} throws"
            self._put_in_use(choice.library, info, message=line)
        else:
            kept = f"version {self.library_version.id}" if self.library_version is not None else "the library in use"
            line = f"kept {kept}; {label} is kept in the library folder, not in use"
            if choice.version is None:
                line = f"kept {kept}; the trained library is not in use"
        changes: dict[str, Any] = {"library_choice": None, "message": line}
        if outcome is not None:
            changes["training_outcome"] = outcome.decided(use)
        self._update(Event.TRAINING, **changes)
        return line

    def _put_in_use(self, library: ThrowLibrary, version: VersionInfo | None, *, message: str | None = None) -> None:
        """Throw with `library` (version `version` of the folder) from now on; measured throws join it."""
        library.require_arm(self.world.arm_model.name)
        self._library, self._version, self._planner, self._learning = library, version, None, None
        note = self._calibration_note()
        changes: dict[str, Any] = {"preview": None}
        if message is not None or note:
            changes["message"] = " · ".join(m for m in (message, note) if m)
        self._update(Event.PLANNER, **changes)

    # -- the calibration it was trained with ----------------------------------------------------------

    def calibration_fingerprint(self) -> str | None:
        """The fingerprint of the rig's calibration now (None: not calibrated)."""
        Ps = self.world.rig.Ps
        return None if Ps is None else calibration_fingerprint(Ps, "link1")

    def _calibration_note(self) -> str:
        """The calibration line (`calibration_note`) for the version in use, once per pair."""
        version, fingerprint = self.library_version, self.calibration_fingerprint()
        note = calibration_note(version, fingerprint)
        if not note or version is None or fingerprint is None or (version.id, fingerprint) in self._noted:
            return ""
        self._noted.add((version.id, fingerprint))
        return note

    def tell_calibration_note(self) -> None:
        """Say the calibration line, if there is one not said yet (before a throw is planned)."""
        note = self._calibration_note()
        if note:
            self.tell(note)

    # -- the learning and the planner -----------------------------------------------------------------

    @property
    def learning_library(self) -> LearningLibrary:
        """The library that measured throws join (made from `library` when first needed)."""
        if self._learning is None:
            origin = "the library the command gave" if self._library_given else "the shipped library"
            self._learning = LearningLibrary(
                self.library,
                self.world.arm_model,
                store=self._store,
                version=self._version,
                calibration=self.calibration_fingerprint,
                origin=origin,
            )
        return self._learning

    @property
    def planner(self) -> ThrowPlanner | AnalyticPlanner:
        if self._planner is None:
            kind = AnalyticPlanner if self._analytic else ThrowPlanner
            regression = self.learning_library.online  # before any join: the training fit itself
            self._planner = kind(self.world.arm_model, self.library, margin=self.margin_m, generalizer=regression)
        return self._planner
