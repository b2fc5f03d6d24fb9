"""Where a library folder is, and the library a session starts with from it.

A library folder (`wiithrow.app.throws.library_store.LibraryStore`: every version of one arm's
library and the one in use) lives where the lab says (`library_folder`):

* the settings' `library_folder` (a relative path is taken from the settings file's folder), or a
  command's `--library-folder`;
* else, on the hardware path, beside the calibration the command measures with
  (`<calibration's folder>/<arm>-library`), or beside the settings file without one;
* else, in a simulated world, a folder of that world's own (`<arm>-<world>` under
  `$WIITHROW_SIM_LIBRARIES`, else the cache folder's `libraries`, beside the simulated rig's kept
  calibrations): the simulated worlds' libraries never mix with each other's or the hardware's.

Before versions, a trained library was written to the user's cache as `<arm>_trained_library.json`,
shared by every world. The first time a library folder of that arm is opened (`open_library_folder`)
that file is read once and kept as a version of the folder, not in use, with a one-line notice;
nothing writes it any more.

`starting_library`: the library a command's session starts with: the file it names (`--library`,
kept as a version and put in use, unless it is the version in use already), else the folder's
version in use, else none (the session then throws with the shipped library).
"""

from __future__ import annotations

import os
from collections.abc import Callable
from pathlib import Path

from wiithrow.app.calibration.simulated import cache_dir
from wiithrow.app.throws.library_file import load_library
from wiithrow.app.throws.library_store import LibraryStore, VersionInfo
from wiithrow.throwing import ThrowLibrary

#: The environment variable that moves every simulated world's library folder (the test suite's).
SIM_LIBRARIES_ENV = "WIITHROW_SIM_LIBRARIES"
#: Where a training wrote its library before versions (in the cache folder).
OLD_CACHE_NAME = "{arm}_trained_library.json"


def simulated_libraries() -> Path:
    """The folder of the simulated worlds' library folders (module docstring)."""
    given = os.environ.get(SIM_LIBRARIES_ENV)
    return Path(given) if given else cache_dir() / "libraries"


def library_folder(
    arm: str,
    *,
    given: str | os.PathLike[str] | None = None,
    settings_folder: str = "",
    settings_path: str | os.PathLike[str] | None = None,
    calibration_path: str | os.PathLike[str] | None = None,
    world: str | None = None,
) -> Path:
    """The library folder of `arm` (module docstring): `given` (a command's flag), else the settings'
    `settings_folder` (relative to `settings_path`'s folder), else the simulated `world`'s, else
    beside the calibration, else beside the settings file, else `./<arm>-library`."""
    if given:
        return Path(given).expanduser()
    if settings_folder:
        folder = Path(settings_folder).expanduser()
        if not folder.is_absolute() and settings_path is not None:
            folder = Path(settings_path).resolve().parent / folder
        return folder
    if world is not None:
        return simulated_libraries() / f"{arm}-{world}"
    beside = calibration_path or settings_path
    if beside is not None:
        return Path(beside).resolve().parent / f"{arm}-library"
    return Path(f"{arm}-library").resolve()


def open_library_folder(folder: str | os.PathLike[str], arm: str, say: Callable[[str], None]) -> LibraryStore:
    """The library folder at `folder`, the old cache file of `arm` kept in it once (module docstring)."""
    store = LibraryStore(folder)
    old = cache_dir() / OLD_CACHE_NAME.format(arm=arm)
    if not old.is_file() or any(v.how == "migration" for v in store.versions()):
        return store
    try:
        library = load_library(old)
        library.require_arm(arm)
    except Exception as exc:  # a file we cannot use is left as it is, and said
        say(f"{old}: a library trained before versions, not kept ({exc}); it is left as it is")
        return store
    info = store.add(
        library, parent=None, by="command", how="migration", note=f"read from {old} (its world is not recorded)",
        calibration=None, heldout=None,
    )  # fmt: skip
    say(
        f"a library trained before versions, {old}, is kept as version {info.id} of {store.folder}, not in use "
        f"(`wiithrow library use {info.id}` puts it in use); that file is no longer written"
    )
    return store


def starting_library(
    store: LibraryStore,
    library_path: str | os.PathLike[str] | None,
    arm: str,
    say: Callable[[str], None],
    *,
    keep: bool = True,
) -> tuple[ThrowLibrary | None, VersionInfo | None]:
    """The library a session starts with, and its version (module docstring); `keep`: a file
    given is kept as a version (False: a dry run, nothing written)."""
    current = store.in_use()
    if library_path is None:
        return (current[1], current[0]) if current is not None else (None, None)
    library = load_library(library_path)
    library.require_arm(arm)
    if current is not None and current[1].to_dict() == library.to_dict():
        return library, current[0]
    if not keep:
        return library, None
    info = store.add(
        library, parent=current[0].id if current is not None else None, by="command", how="import",
        note=f"imported from {library_path}", calibration=None, heldout=None, use=True,
    )  # fmt: skip
    say(f"{library_path} kept as library version {info.id} of {store.folder}, in use")
    return library, info
