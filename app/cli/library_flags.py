"""The library folder of a command, and the choice a command makes about a trained library.

`add_library_folder_argument` / `store_from_args`: `--library-folder DIR` on the commands that
throw or train (`demo`, `serve`, `throw`, `train`), else the folder the settings or the world say
(`wiithrow.app.session.library_folder.library_folder`): the folder is opened with its one-time
migration of the old cache file said on stderr.

`library_in_use`: the library a command that throws starts with, named in one line and as `--json`
reports it: a version of the folder, the file `--library` gave (on a dry run, not kept), or the
shipped library.

`add_choice_arguments` / `use_from_args` / `print_comparison`: what a command that trains does
with its new library: by default it is kept as a version, not in use, and the comparison with the
library in use is printed as a table with how to use it (`wiithrow library use N`); `--use` puts it
in use (an explicit choice); `--use-if-better` (for scripts) puts it in use only when the
comparison says it is better, else keeps the one in use and says why.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any

from wiithrow.app.session.library_folder import library_folder, open_library_folder
from wiithrow.app.throws.library_compare import Comparison, compare_libraries, table_text
from wiithrow.app.throws.library_file import default_library_path, load_library
from wiithrow.app.throws.library_store import Heldout, LibraryStore, VersionInfo
from wiithrow.app.worlds.base import RigWorld
from wiithrow.throwing import LeaveOneOutResult, ThrowLibrary


def add_library_arguments(parser: argparse.ArgumentParser, *, shipped: str = "the shipped one") -> None:
    """`--library FILE` (kept as a version of the folder and put in use; by default the folder's version
    in use, else `shipped`) and `--library-folder` (`add_library_folder_argument`)."""
    parser.add_argument(
        "--library",
        default=None,
        help="throw library JSON, kept as a version of the library folder and put in use (default: the folder's "
        f"version in use, else {shipped})",
    )
    add_library_folder_argument(parser)


def add_library_folder_argument(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--library-folder",
        metavar="DIR",
        help="the folder of the arm's throw library, its versions and the one in use (default: the settings' "
        "library_folder, else beside the calibration; in simulation a folder of the world's own)",
    )


def store_from_args(
    args: argparse.Namespace,
    command: str,
    *,
    arm: str,
    settings_folder: str = "",
    settings_path: str | None = None,
    calibration_path: str | None = None,
    world: str | None = None,
) -> LibraryStore:
    """The command's library folder (module docstring), its migration notice on stderr."""
    folder = library_folder(
        arm,
        given=getattr(args, "library_folder", None),
        settings_folder=settings_folder,
        settings_path=settings_path,
        calibration_path=calibration_path,
        world=world,
    )
    return open_library_folder(folder, arm, lambda line: print(f"wiithrow {command}: {line}", file=sys.stderr))


def library_in_use(
    store: LibraryStore, library_path: str | None, version: VersionInfo | None
) -> tuple[str, dict[str, Any]]:
    """The library a command starts with (`starting_library`'s `version`; `library_path`: its
    `--library`), as one line and as `--json`'s keys (module docstring)."""
    folder = str(store.folder)
    if version is not None:
        given = f", from --library {library_path}" if library_path else ""
        line = f"library: version {version.id} of {folder} (in use{given}; `wiithrow library list` shows them)"
        return line, {"source": "version", "version": version.id, "folder": folder, "file": str(store.path(version.id))}
    if library_path:
        line = f"library: {library_path} (--library; not kept as a version: a dry run)"
        return line, {"source": "file", "version": None, "folder": folder, "file": str(library_path)}
    shipped = str(default_library_path())
    line = f"library: the shipped library, {shipped} (no version in use in {folder}; --library to give one)"
    return line, {"source": "shipped", "version": None, "folder": folder, "file": shipped}


def add_choice_arguments(parser: argparse.ArgumentParser) -> None:
    choice = parser.add_mutually_exclusive_group()
    choice.add_argument("--use", action="store_true", help="put the new library in use, whatever the comparison says")
    choice.add_argument(
        "--use-if-better",
        action="store_true",
        help="put the new library in use only when it is better than the one in use (held-out error, area, "
        "throws); else keep the one in use and say why",
    )


def use_from_args(args: argparse.Namespace) -> str:
    """`finish_training`'s `use` for the command's flags: "always", "if_better" or "ask" (kept, not used)."""
    if getattr(args, "use", False):
        return "always"
    return "if_better" if getattr(args, "use_if_better", False) else "ask"


def print_comparison(comparison: Comparison, used: bool | None, version: int | None, folder: Path | None) -> None:
    """The comparison table and what was done, on stderr (stdout stays the command's result)."""
    for line in table_text(comparison):
        print(f"  {line}", file=sys.stderr)
    print(f"  {comparison.verdict()}", file=sys.stderr)
    where = f"version {version} of {folder}" if version is not None and folder is not None else "the new library"
    if used:
        print(f"{where} is in use", file=sys.stderr)
    elif used is False:
        print(f"{where} is kept, not in use: the library in use stays", file=sys.stderr)
    elif version is not None:
        print(f"{where} is kept, not in use: `wiithrow library use {version}` puts it in use", file=sys.stderr)


def keep_trained_library(
    args: argparse.Namespace,
    command: str,
    world: RigWorld,
    library: ThrowLibrary,
    heldout: LeaveOneOutResult,
    calibration: str | None,
) -> dict[str, Any]:
    """A library trained by `command` in `world`: kept as a version of the library folder,
    compared with the version in use (else the shipped library), put in use as the flags choose
    (`use_from_args`), the table on stderr; returns the JSON keys that say so."""
    arm = world.arm_model
    settings_path = getattr(args, "settings", None)
    store = store_from_args(
        args,
        command,
        arm=arm.name,
        settings_folder=world.settings.library_folder if settings_path else "",
        settings_path=settings_path,
        calibration_path=getattr(args, "calibration", None),
        world=None if settings_path else (getattr(args, "world", None) or "mujoco"),
    )
    current = store.in_use()
    if current is not None:
        old, old_label = current[1], f"version {current[0].id} (in use)"
    else:
        old, old_label = load_library(), "the shipped library"
        if old.arm != arm.name:
            old, old_label = None, "none"
    comparison = compare_libraries(
        library, old, arm, old_label=old_label, new_refit=Heldout.of(heldout.errors, "refit")
    )
    info = store.add(
        library,
        parent=current[0].id if current is not None else None,
        by="command",
        how="training",
        note=f"{len(library)} throws, `wiithrow {command}`",
        calibration=calibration,
        heldout=Heldout.of(heldout.errors, "refit"),
    )
    use = use_from_args(args)
    used: bool | None = None
    if use == "always" or (use == "if_better" and comparison.better):
        store.use(info.id, "command")
        used = True
    elif use == "if_better":
        used = False
    print_comparison(comparison, used, info.id, store.folder)
    return {
        "library_folder": str(store.folder),
        "version": info.id,
        "in_use": used is True,
        "comparison": comparison.to_dict(),
    }
