"""The trained-throw library on disk: versioned JSON, written atomically.

The default library for the simulated PA-10 ships with the package (`throwing/data/
pa10_sim_library.json`, made by `wiithrow train --sim`); a user's own replaces it with
`--library FILE`. A corrupt or wrong-version file is reported with its name and never overwritten.
"""

from __future__ import annotations

import json
import os
from importlib import resources
from pathlib import Path

from wiithrow.throwing import LibraryFormatError, ThrowLibrary
from wiithrow.vision.errors import FileFormatError, FileTooLargeError
from wiithrow.vision.files import LIBRARY_SIZE, atomic_write_text, loads_json, read_text

DEFAULT_LIBRARY = "pa10_sim_library.json"


def default_library_path() -> Path:
    """Where the shipped library of the simulated PA-10 lives."""
    return Path(str(resources.files("wiithrow.throwing") / "data" / DEFAULT_LIBRARY))


def save_library(path: str | os.PathLike[str], library: ThrowLibrary) -> Path:
    return atomic_write_text(path, json.dumps(library.to_dict(), indent=1) + "\n")


def load_library(path: str | os.PathLike[str] | None = None) -> ThrowLibrary:
    """The library at `path` (default: the shipped one); FileFormatError names a bad file, and
    one larger than `LIBRARY_SIZE` is refused before it is read."""
    path = Path(path) if path is not None else default_library_path()
    if not path.exists():
        hint = " (make it with `wiithrow train --sim`)" if path == default_library_path() else ""
        raise FileFormatError(f"{path}: no such throw library{hint}")
    try:
        text = read_text(path, LIBRARY_SIZE)
    except FileTooLargeError:
        raise
    except FileFormatError as exc:
        raise FileFormatError(f"{exc}: not a readable throw library; restore it or train a new one") from None
    try:
        document = loads_json(text, str(path))
    except FileFormatError as exc:
        raise FileFormatError(f"{exc}; restore the throw library or train a new one") from None
    try:
        return ThrowLibrary.from_dict(document)
    except LibraryFormatError as exc:
        raise FileFormatError(f"{path}: {exc}") from None
