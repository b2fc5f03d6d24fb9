"""A library's folder: every version of one arm's throw library, and which one is in use.

Every finished training, every import of a library file and every learning update makes a new
version; nothing is overwritten. The folder holds:

    v000001.json, v000002.json, ...   one version each (kind "wiithrow.library_version")
    in_use.json                       which version is in use (kind "wiithrow.library_in_use")

A version records its `parent` (the version it was made from: the one in use when a training
finished, the learning's previous step), `made` (when, by whom: "operator" (the dashboard),
"command" (the command line), "learning"; how: "training", "learning", "import", "migration"; and
a one-line note), the arm, the fingerprint of the calibration its labels were measured with, its
number of throws, its held-out error (and how it was measured), the area it covers (the hull of
its landings) and, for a learning step, what the step did (`learning`: the throw's join number,
its source, the parent's held-out error measured the same way, whether it was used and why not),
then the library itself.

**Writes** (`add`, `use`) are atomic and ordered so that a crash or a power loss at any point
leaves the version in use intact and in use: a version's file is written to a temporary file
beside it, fsync'ed, then linked to its name (a link fails if the name exists: two writers never
share a number) and the folder fsync'ed; only then is `in_use.json` replaced (temporary file,
fsync, rename, folder fsync). A crash before the rename leaves the new version on disk, not in
use; a temporary file a crash left behind is hidden (`.v....tmp`) and removed by a later write once
it is `STALE_TEMP_S` old.

**Bounded** (`thin`, after every write): every version that is not a learning step is kept
(trainings, imports: a person's work); of the learning steps the newest `KEEP_LEARNING` are kept,
and of the older ones those whose number is a multiple of `THIN_EVERY`, the newest
`KEEP_THINNED` of them; whatever was put in use by the last `KEEP_RECENT_USES` changes of the
library in use is kept too, and the version in use always. So however many throws join, a folder
holds at most its trainings and imports plus `KEEP_LEARNING + KEEP_THINNED + KEEP_RECENT_USES + 1`
learning steps (a learning step is its throws' 0.3 KB each and the fit: 32 KB at 96 throws, under
0.1 MB at the library's bound of 200; 1,000 updates of the shipped library left 40 versions, 1.2 MB).

A version whose file cannot be read is listed as broken (never removed); `in_use` naming one is
refused in one line that says how to choose another (`wiithrow library use N`).
"""

from __future__ import annotations

import contextlib
import os
import re
import shutil
import time
from dataclasses import dataclass, field, replace
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

import numpy as np

from wiithrow.app.errors import AppError
from wiithrow.throwing import LibraryFormatError, ThrowingError, ThrowLibrary
from wiithrow.throwing.generalize import TrainedArea
from wiithrow.vision.errors import FileFormatError
from wiithrow.vision.files import (
    DOCUMENT_SIZE,
    LIBRARY_SIZE,
    atomic_write_text,
    dumps_strict,
    loads_json,
    read_text,
    sync_folder,
    write_temp_beside,
)

VERSION_KIND = "wiithrow.library_version"
IN_USE_KIND = "wiithrow.library_in_use"
SCHEMA = 1
IN_USE = "in_use.json"
#: Who made a version.
MADE_BY = ("operator", "command", "learning")
#: How it was made.
HOW = ("training", "learning", "import", "migration")
#: The newest learning steps kept whole (module docstring): the last minutes of a working arm.
KEEP_LEARNING = 20
#: Of the older learning steps, those whose number is a multiple of this are kept...
THIN_EVERY = 50
#: ... the newest this many of them: a sparse record of where the learning went, back to ~1,000 steps.
KEEP_THINNED = 20
#: The versions put in use by the last this many changes of the version in use are kept (a way back).
KEEP_RECENT_USES = 20
#: A temporary file older than this (s) was left by a crash: a later write removes it.
STALE_TEMP_S = 3600.0

_VERSION_NAME = re.compile(r"^v(\d{6,})\.json$")


def _now() -> str:
    return datetime.now(UTC).isoformat(timespec="seconds")


@dataclass(frozen=True)
class Heldout:
    """A library's held-out error (m): mean, median, max over `count` throws, and the `method`
    ("refit": `generalize.regression_leave_one_out_error`, each fold refitted; "fixed": the closed
    form of `throwing.online_heldout`, the hyperparameters fixed; "fixed, near the update": the
    same over the throws nearest a learning step's throw)."""

    mean_m: float
    median_m: float
    max_m: float
    method: str
    count: int

    @classmethod
    def of(cls, errors: Any, method: str) -> Heldout:
        e = np.asarray(errors, dtype=float)
        return cls(float(np.mean(e)), float(np.median(e)), float(np.max(e)), method, int(e.size))

    def to_dict(self) -> dict[str, Any]:
        return {
            "mean_m": self.mean_m,
            "median_m": self.median_m,
            "max_m": self.max_m,
            "method": self.method,
            "count": self.count,
        }

    @classmethod
    def from_dict(cls, d: Any) -> Heldout | None:
        if d is None:
            return None
        return cls(_number(d["mean_m"]), _number(d["median_m"]), _number(d["max_m"]), str(d["method"]), int(d["count"]))

    def line(self) -> str:
        return f"mean {1e3 * self.mean_m:.1f} mm, max {1e3 * self.max_m:.1f} mm ({self.method}, {self.count} throws)"


def _number(value: Any) -> float:
    """A JSON number, or null read as infinity (a held-out throw that never lands)."""
    return float("inf") if value is None else float(value)


@dataclass(frozen=True)
class AreaFigures:
    """The area a library covers: the hull of its landings, its bounds (link1 x, z, m) and its
    size (m^2); `throws` the landings it is made of."""

    x_m: tuple[float, float]
    z_m: tuple[float, float]
    hull_m2: float

    @classmethod
    def of(cls, library: ThrowLibrary) -> AreaFigures | None:
        try:
            area = TrainedArea(library.landings)
        except ThrowingError:  # fewer than 3 landings, or in a line: no area
            return None
        v = area.vertices
        hull = 0.5 * abs(float(np.dot(v[:, 0], np.roll(v[:, 1], -1)) - np.dot(v[:, 1], np.roll(v[:, 0], -1))))
        (x0, x1), (z0, z1) = area.bounds
        return cls((x0, x1), (z0, z1), hull)

    def to_dict(self) -> dict[str, Any]:
        return {"x_m": list(self.x_m), "z_m": list(self.z_m), "hull_m2": self.hull_m2}

    @classmethod
    def from_dict(cls, d: Any) -> AreaFigures | None:
        if d is None:
            return None
        return cls(
            (float(d["x_m"][0]), float(d["x_m"][1])), (float(d["z_m"][0]), float(d["z_m"][1])), float(d["hull_m2"])
        )

    def line(self) -> str:
        return (
            f"x {self.x_m[0]:.2f}-{self.x_m[1]:.2f} m, z {self.z_m[0]:.2f}-{self.z_m[1]:.2f} m, "
            f"{1e4 * self.hull_m2:.0f} cm^2"
        )


@dataclass(frozen=True)
class VersionInfo:
    """One version's record (module docstring), without its library; `broken`: why its file could
    not be read ("" when it could)."""

    id: int
    parent: int | None = None
    time: str = ""
    by: str = ""
    how: str = ""
    note: str = ""
    arm: str = ""
    calibration: str | None = None
    throws: int = 0
    heldout: Heldout | None = None
    area: AreaFigures | None = None
    learning: dict[str, Any] | None = None
    broken: str = ""

    @property
    def name(self) -> str:
        return f"v{self.id:06d}.json"

    @property
    def used_by_learning(self) -> bool:
        """False for a learning step that was kept but not used (its held-out error was worse)."""
        return self.learning is None or bool(self.learning.get("used", True))

    def to_dict(self) -> dict[str, Any]:
        return {
            "id": self.id,
            "parent": self.parent,
            "made": {"time": self.time, "by": self.by, "how": self.how, "note": self.note},
            "arm": self.arm,
            "calibration": self.calibration,
            "throws": self.throws,
            "heldout": None if self.heldout is None else self.heldout.to_dict(),
            "area": None if self.area is None else self.area.to_dict(),
            "learning": self.learning,
        }

    @classmethod
    def from_dict(cls, d: Any, where: str) -> VersionInfo:
        try:
            made = d["made"]
            info = cls(
                int(d["id"]),
                None if d["parent"] is None else int(d["parent"]),
                str(made["time"]),
                str(made["by"]),
                str(made["how"]),
                str(made["note"]),
                str(d["arm"]),
                None if d["calibration"] is None else str(d["calibration"]),
                int(d["throws"]),
                Heldout.from_dict(d["heldout"]),
                AreaFigures.from_dict(d["area"]),
                None if d.get("learning") is None else dict(d["learning"]),
            )
        except (KeyError, TypeError, ValueError, IndexError) as exc:
            raise FileFormatError(f"{where}: not a library version ({exc!r})") from None
        if info.by not in MADE_BY or info.how not in HOW:
            raise FileFormatError(f"{where}: made by {info.by!r} / {info.how!r}, not one of {MADE_BY} / {HOW}")
        return info


@dataclass(frozen=True)
class InUse:
    """What `in_use.json` says: the version in use, since when, who put it there, and the versions
    put in use by the last changes (newest last)."""

    id: int
    since: str
    by: str
    recent: tuple[int, ...] = field(default=())


class LibraryStore:
    """The versions of one arm's library in `folder` (module docstring)."""

    def __init__(self, folder: str | os.PathLike[str]) -> None:
        self.folder = Path(folder)
        self._cache: dict[str, tuple[tuple[int, int], VersionInfo]] = {}

    def __repr__(self) -> str:
        return f"LibraryStore({str(self.folder)!r})"

    # -- reading ---------------------------------------------------------------------------------

    def ids(self) -> list[int]:
        """The versions' numbers on disk, oldest first."""
        if not self.folder.is_dir():
            return []
        found = (_VERSION_NAME.match(p.name) for p in self.folder.iterdir())
        return sorted(int(m.group(1)) for m in found if m)

    def path(self, version: int) -> Path:
        return self.folder / f"v{version:06d}.json"

    def versions(self) -> list[VersionInfo]:
        """Every version's record, oldest first (a broken file says why in its `broken`)."""
        return [self.info(i) for i in self.ids()]

    def info(self, version: int) -> VersionInfo:
        """Version `version`'s record (read once per change of its file)."""
        path = self.path(version)
        try:
            st = path.stat()
        except OSError:
            raise AppError(f"{self.folder}: there is no library version {version} ({self._choices()})") from None
        key = (st.st_mtime_ns, st.st_size)
        cached = self._cache.get(path.name)
        if cached is not None and cached[0] == key:
            return cached[1]
        try:
            info = VersionInfo.from_dict(self._document(path), str(path))
        except FileFormatError as exc:
            info = VersionInfo(version, broken=str(exc))
        self._cache[path.name] = (key, info)
        return info

    def load(self, version: int) -> tuple[VersionInfo, ThrowLibrary]:
        """Version `version`'s record and library (AppError naming the file when it is broken)."""
        path = self.path(version)
        if not path.exists():
            raise AppError(f"{self.folder}: there is no library version {version} ({self._choices()})")
        try:
            document = self._document(path)
            info = VersionInfo.from_dict(document, str(path))
            library = ThrowLibrary.from_dict(document.get("library"))
        except (FileFormatError, LibraryFormatError) as exc:
            raise AppError(f"{exc}: library version {version} cannot be used; choose another") from None
        return info, library

    def _document(self, path: Path) -> dict[str, Any]:
        document = loads_json(read_text(path, LIBRARY_SIZE), str(path))
        if not isinstance(document, dict) or document.get("kind") != VERSION_KIND:
            raise FileFormatError(f"{path}: not a library version (kind {VERSION_KIND!r} expected)")
        if document.get("schema") != SCHEMA:
            raise FileFormatError(f"{path}: library version schema {document.get('schema')!r} (this reads {SCHEMA})")
        return document

    def in_use_record(self) -> InUse | None:
        """What `in_use.json` says, or None when no version was put in use."""
        path = self.folder / IN_USE
        if not path.exists():
            return None
        try:
            d = loads_json(read_text(path, DOCUMENT_SIZE), str(path))
            if not isinstance(d, dict) or d.get("kind") != IN_USE_KIND or d.get("schema") != SCHEMA:
                raise FileFormatError(f"{path}: not a record of the library in use")
            return InUse(int(d["id"]), str(d["since"]), str(d["by"]), tuple(int(i) for i in d.get("recent", [])))
        except (FileFormatError, KeyError, TypeError, ValueError) as exc:
            raise AppError(f"{exc}: choose the version in use again (`wiithrow library use N`)") from None

    def in_use(self) -> tuple[VersionInfo, ThrowLibrary] | None:
        """The version in use and its library, or None when none was put in use."""
        record = self.in_use_record()
        if record is None:
            return None
        try:
            return self.load(record.id)
        except AppError as exc:
            raise AppError(f"{exc} (`wiithrow library use N`, N from `wiithrow library list`)") from None

    def _choices(self) -> str:
        ids = self.ids()
        return f"versions {ids[0]}-{ids[-1]}" if ids else "no version yet"

    # -- writing ---------------------------------------------------------------------------------

    def add(
        self,
        library: ThrowLibrary,
        *,
        parent: int | None,
        by: str,
        how: str,
        note: str,
        calibration: str | None,
        heldout: Heldout | None,
        learning: dict[str, Any] | None = None,
        use: bool = False,
    ) -> VersionInfo:
        """Write `library` as a new version (module docstring: atomic, never over another) and, if
        `use`, put it in use; returns its record. AppError for a library of another arm than the
        folder's versions, or an unknown `by`/`how`."""
        if by not in MADE_BY or how not in HOW:
            raise AppError(f"a library version is made by one of {MADE_BY} and how one of {HOW}: {by!r}, {how!r}")
        arm = self.arm()
        if arm is not None and arm != library.arm:
            raise AppError(
                f"{self.folder} holds the library of arm {arm!r}, and this one is of arm {library.arm!r}: "
                "give each arm its own library folder"
            )
        self.folder.mkdir(parents=True, exist_ok=True)
        self._remove_stale_temps()
        ids = self.ids()
        number = (ids[-1] if ids else 0) + 1
        info = VersionInfo(
            number, parent, _now(), by, how, note, library.arm, calibration, len(library), heldout,
            AreaFigures.of(library), learning,
        )  # fmt: skip
        while True:
            target = self.path(number)
            tmp = write_temp_beside(target, _version_bytes(info, library))
            try:
                _link_new(tmp, target)
                break
            except FileExistsError:  # another writer took the number: the next one
                number += 1
                info = replace(info, id=number)
            finally:
                tmp.unlink(missing_ok=True)
        sync_folder(self.folder)
        if use:
            self.use(number, by)
        else:
            self.thin()
        return info

    def use(self, version: int, by: str) -> VersionInfo:
        """Put version `version` in use (it must load); returns its record."""
        info, _ = self.load(version)
        before = self.in_use_record()
        recent = (*(before.recent if before is not None else ()), version)[-KEEP_RECENT_USES:]
        document = {"kind": IN_USE_KIND, "schema": SCHEMA, "id": version, "since": _now(), "by": by,
                    "recent": list(recent)}  # fmt: skip
        atomic_write_text(self.folder / IN_USE, dumps_strict(document, indent=1) + "\n")
        self.thin()
        return info

    def arm(self) -> str | None:
        """The arm of the folder's versions (the first readable one's), None when there is none."""
        for i in self.ids():
            info = self.info(i)
            if not info.broken:
                return info.arm
        return None

    # -- bounds ----------------------------------------------------------------------------------

    def kept(self, infos: list[VersionInfo], record: InUse | None) -> set[int]:
        """The versions the thinning keeps (module docstring)."""
        keep = {v.id for v in infos if v.how != "learning" or v.broken}
        if record is not None:
            keep |= {record.id, *record.recent}
        learning = [v.id for v in infos if v.how == "learning" and not v.broken]
        keep |= set(learning[-KEEP_LEARNING:])
        older = [i for i in learning[:-KEEP_LEARNING] if i % THIN_EVERY == 0]
        keep |= set(older[-KEEP_THINNED:])
        return keep

    def thin(self) -> list[int]:
        """Remove the learning steps the bound does not keep; returns their numbers."""
        infos = self.versions()
        keep = self.kept(infos, self.in_use_record())
        gone = [v.id for v in infos if v.id not in keep]
        for i in gone:
            self.path(i).unlink(missing_ok=True)
        if gone:
            sync_folder(self.folder)
        return gone

    def _remove_stale_temps(self) -> None:
        now = time.time()
        for p in self.folder.glob(".*.tmp"):
            with contextlib.suppress(OSError):
                if now - p.stat().st_mtime > STALE_TEMP_S:
                    p.unlink()

    # -- moving ----------------------------------------------------------------------------------

    def move(self, destination: str | os.PathLike[str]) -> LibraryStore:
        """Move every version and the record of the one in use to `destination` (a folder that
        does not exist, or is empty). On one file system the folder is renamed (atomic); across
        file systems each file is copied atomically and read back, the record of the version in
        use last, and only then are the originals removed: a crash leaves the originals whole."""
        dest = Path(destination)
        if dest.resolve() == self.folder.resolve():
            raise AppError(f"{dest} is where the library is already")
        if dest.exists() and (not dest.is_dir() or any(dest.iterdir())):
            raise AppError(f"{dest} exists and is not an empty folder: the library is moved only to a new place")
        if not self.folder.is_dir():
            raise AppError(f"{self.folder}: no library folder to move")
        dest.parent.mkdir(parents=True, exist_ok=True)
        with contextlib.suppress(FileNotFoundError):
            dest.rmdir()
        try:
            os.rename(self.folder, dest)
            sync_folder(dest.parent)
            sync_folder(self.folder.parent)
            return LibraryStore(dest)
        except OSError:  # another file system: copy, check, then remove
            pass
        dest.mkdir(parents=True)
        names = sorted(p.name for p in self.folder.iterdir() if not p.name.startswith("."))
        for name in (n for n in names if n != IN_USE):
            atomic_write_text(dest / name, (self.folder / name).read_text(encoding="utf-8"))
        moved = LibraryStore(dest)
        for i in moved.ids():
            moved.load(i)  # every version reads back
        if IN_USE in names:
            atomic_write_text(dest / IN_USE, (self.folder / IN_USE).read_text(encoding="utf-8"))
        shutil.rmtree(self.folder)
        return moved


def _link_new(tmp: Path, target: Path) -> None:
    """Give the written `tmp` the name `target`, never over an existing file (FileExistsError)."""
    try:
        os.link(tmp, target)
    except FileExistsError:
        raise
    except OSError:  # a file system without hard links: the name checked, then renamed
        if target.exists():
            raise FileExistsError(target) from None
        os.rename(tmp, target)


def _version_bytes(info: VersionInfo, library: ThrowLibrary) -> bytes:
    """A version's file: its record, then its library (strict JSON)."""
    text = dumps_strict({"kind": VERSION_KIND, "schema": SCHEMA, **info.to_dict(), "library": library.to_dict()})
    return (text + "\n").encode("utf-8")
