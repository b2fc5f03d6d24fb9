"""Atomic, versioned files.

Every file the project writes goes through here: the bytes are written to a temporary file in the
same folder, flushed and fsync'ed, then renamed over the destination, so a crash leaves either the
old file or the new one, never half of each. JSON documents carry a `kind` and a `schema` version;
reading checks both and names the file in every error, and a failed read never touches the file.
"""

from __future__ import annotations

import json
import os
import tempfile
from pathlib import Path
from typing import Any

from wiithrow.vision.errors import FileFormatError


def atomic_write_bytes(path: str | os.PathLike[str], data: bytes) -> Path:
    """Write `data` to `path` atomically (temp file in the same folder, fsync, rename)."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    try:
        with os.fdopen(fd, "wb") as handle:
            handle.write(data)
            handle.flush()
            os.fsync(handle.fileno())
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise
    try:  # make the rename itself durable where the platform allows it
        dir_fd = os.open(path.parent, os.O_RDONLY)
    except OSError:
        return path
    try:
        os.fsync(dir_fd)
    except OSError:
        pass
    finally:
        os.close(dir_fd)
    return path


def atomic_write_text(path: str | os.PathLike[str], text: str) -> Path:
    """Write UTF-8 `text` to `path` atomically."""
    return atomic_write_bytes(path, text.encode("utf-8"))


def read_text(path: str | os.PathLike[str]) -> str:
    """The UTF-8 text of `path`; `FileFormatError`, naming the file, when it is missing or cannot
    be read."""
    try:
        return Path(path).read_text(encoding="utf-8")
    except FileNotFoundError:
        raise FileFormatError(f"{path}: no such file") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise FileFormatError(f"{path}: cannot be read ({exc})") from None


def write_versioned_json(path: str | os.PathLike[str], kind: str, schema: int, payload: dict[str, Any]) -> Path:
    """Write `payload` as a JSON document tagged with its `kind` and `schema` version, atomically."""
    document = {"kind": kind, "schema": schema, **payload}
    return atomic_write_text(path, json.dumps(document, indent=2, allow_nan=True) + "\n")


def read_versioned_json(path: str | os.PathLike[str], kind: str, schema: int) -> dict[str, Any]:
    """Read a JSON document written by `write_versioned_json`, checking its kind and schema version.

    Raises `FileFormatError`, naming the file, when it is missing, not JSON, of another kind or of
    another schema version.
    """
    path = Path(path)
    text = read_text(path)
    try:
        document = json.loads(text)
    except json.JSONDecodeError as exc:
        raise FileFormatError(
            f"{path}: not valid JSON (line {exc.lineno}, column {exc.colno}: {exc.msg}); "
            "the file is corrupt: restore it or write a new one"
        ) from None
    if not isinstance(document, dict):
        raise FileFormatError(f"{path}: expected a JSON object, found {type(document).__name__}")
    if document.get("kind") != kind:
        raise FileFormatError(f"{path}: expected a {kind!r} file, found kind {document.get('kind')!r}")
    if document.get("schema") != schema:
        raise FileFormatError(
            f"{path}: schema version {document.get('schema')!r} is not supported "
            f"(this version of wiithrow reads schema {schema})"
        )
    return document
