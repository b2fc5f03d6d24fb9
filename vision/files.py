"""Atomic, versioned files.

Every file the project writes goes through here: the bytes are written to a temporary file in the
same folder, flushed and fsync'ed, then renamed over the destination, so a crash leaves either the
old file or the new one, never half of each. A new file gets the mode the user's umask gives
(0644 under umask 022: the temporary file is created with 0666 and the kernel applies the umask);
a file that is replaced keeps its mode. JSON is strict: NaN and infinities are written as null
(`strict_json`), so any JSON parser reads what we write. JSON documents carry a `kind` and a
`schema` version; reading checks both and names the file in every error, and a failed read never
touches the file.

JSON read from a file or a message goes through `loads_json`: a document nested deeper than
`MAX_JSON_DEPTH` is refused in one line (`FileFormatError`) before the caller walks it, never a
`RecursionError`; `non_finite_path` finds a NaN or an infinity (a `NaN` token, or a number like
1e999 that overflows) for readers that refuse them, and says where it is.

Every file read from a lab's disk has a size bound (`SizeBound`: the bytes, what the file is, why
that many): `read_text(path, bound)` refuses a larger file in one line (`FileTooLargeError`: the
file, its size, the bound and its reason) from its size (`os.fstat`) before reading any of it, and
reads at most the bound plus one byte (a file that grows meanwhile, or a device that reports no
size, is refused all the same), so a file of any size costs at most its bound in memory. Parsing
JSON costs about six times the text (Python's floats and lists: a 42 MB calibration peaks 244 MB
above the process), so the bounds keep every file the project makes and a margin, no more.

Several files written together, all or none, and checking where they go before the work starts:
`wiithrow.vision.outputs`.
"""

from __future__ import annotations

import json
import math
import os
import re
import secrets
import stat
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import IO, Any

import numpy as np

from wiithrow.vision.errors import FileFormatError, FileTooLargeError, OutputWriteError


def strict_json(value: Any) -> Any:
    """`value` with every non-finite float (NaN, inf) replaced by None, recursively through dicts,
    lists and tuples: what `json.dumps(..., allow_nan=False)` accepts. Numpy scalars and arrays
    become Python numbers and lists."""
    if isinstance(value, np.ndarray):
        value = value.tolist()
    elif isinstance(value, np.generic):
        value = value.item()
    if isinstance(value, float):
        return value if math.isfinite(value) else None
    if isinstance(value, dict):
        return {key: strict_json(item) for key, item in value.items()}
    if isinstance(value, list | tuple):
        return [strict_json(item) for item in value]
    return value


def dumps_strict(value: Any, *, indent: int | None = None) -> str:
    """`value` as strict JSON text: null for NaN and infinities (see `strict_json`). A document
    without them is written as it is (no copy: a calibration of 100,000 points is 40 MB of JSON)."""
    try:
        return json.dumps(value, indent=indent, allow_nan=False, default=_plain)
    except ValueError:  # NaN or infinity somewhere
        return json.dumps(strict_json(value), indent=indent, allow_nan=False)


def dump_strict(value: Any, handle: IO[str], *, indent: int | None = None) -> None:
    """Write `value` as strict JSON to `handle` as it is encoded (`dumps_strict`'s text, without
    holding it whole); `handle` must be seekable, to start again with nulls for NaN."""
    start = handle.tell()
    try:
        json.dump(value, handle, indent=indent, allow_nan=False, default=_plain)
    except ValueError:  # NaN or infinity somewhere
        handle.seek(start)
        handle.truncate()
        json.dump(strict_json(value), handle, indent=indent, allow_nan=False)


def _plain(value: Any) -> Any:
    """Numpy arrays and scalars as lists and numbers, for `json.dumps`."""
    if isinstance(value, np.ndarray | np.generic):
        return value.tolist()
    raise TypeError(f"{type(value).__name__} is not JSON")


def create_temp_beside(path: Path) -> tuple[int, Path]:
    """A new temporary file in `path`'s folder (which must exist), open for writing, with the mode
    `path` will have: `path`'s own when it exists, else 0666 less the umask. Returns its file
    descriptor and path; the caller renames it into place or removes it."""
    while True:
        tmp = path.with_name(f".{path.name}.{secrets.token_hex(4)}.tmp")
        try:
            fd = os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o666)
            break
        except FileExistsError:
            continue
    try:
        if path.exists():
            os.chmod(fd, stat.S_IMODE(path.stat().st_mode))
    except BaseException:
        os.close(fd)
        tmp.unlink(missing_ok=True)
        raise
    return fd, tmp


#: What a file is made of: its bytes, or a function that writes its text to an open handle (a
#: large document written as it is produced, never held whole in memory).
Content = bytes | Callable[[IO[str]], None]


def write_temp_beside(path: Path, content: Content) -> Path:
    """Write `content` to a new temporary file beside `path` (`create_temp_beside`) and fsync it;
    returns the temporary file's path. `OutputWriteError` (one line: nothing was written, the old
    file is as it was) when the disk is full or the write fails otherwise; a failure of `content`
    itself propagates as it is."""
    try:
        fd, tmp = create_temp_beside(path)
    except OSError as exc:
        raise _write_failed(path, exc) from None
    try:
        if isinstance(content, bytes):
            with os.fdopen(fd, "wb") as binary:
                binary.write(content)
                binary.flush()
                os.fsync(binary.fileno())
        else:
            with os.fdopen(fd, "w", encoding="utf-8", newline="") as text:
                content(text)
                text.flush()
                os.fsync(text.fileno())
    except OSError as exc:
        tmp.unlink(missing_ok=True)
        raise _write_failed(path, exc) from None
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise
    return tmp


def _write_failed(path: Path, exc: OSError) -> OutputWriteError:
    return OutputWriteError(
        f"cannot write {path} ({exc.strerror or exc}): nothing was written"
        + ("; the file there is as it was" if path.exists() else "")
    )


def sync_folder(folder: Path) -> None:
    """Make renames in `folder` durable where the platform allows it (fsync of the folder)."""
    try:
        dir_fd = os.open(folder, os.O_RDONLY)
    except OSError:
        return
    try:
        os.fsync(dir_fd)
    except OSError:
        pass
    finally:
        os.close(dir_fd)


def atomic_write_bytes(path: str | os.PathLike[str], data: bytes) -> Path:
    """Write `data` to `path` atomically (temp file in the same folder, fsync, rename)."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = write_temp_beside(path, data)
    try:
        os.replace(tmp, path)
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise
    sync_folder(path.parent)
    return path


def atomic_write_text(path: str | os.PathLike[str], text: str) -> Path:
    """Write UTF-8 `text` to `path` atomically."""
    return atomic_write_bytes(path, text.encode("utf-8"))


MiB = 2**20


@dataclass(frozen=True)
class SizeBound:
    """How large a kind of file may be: `max_bytes`, `what` it is ("a calibration"), and `reason`,
    the largest legitimate file and the margin (said in the refusal)."""

    max_bytes: int
    what: str
    reason: str

    def refusal(self, path: str | os.PathLike[str], size: int) -> FileTooLargeError:
        """The one line that refuses `path` of `size` bytes (at least; more than the bound)."""
        return FileTooLargeError(
            f"{path}: {size / 1e6:.1f} MB, more than {self.what} may be ({self.max_bytes / MiB:g} MiB: "
            f"{self.reason}); nothing of it was read"
        )


#: A settings file: the largest the project ships (an `arm_spec` with every figure) is 4 KB.
SETTINGS_SIZE = SizeBound(1 * MiB, "a settings file", "one with a whole arm spec is 4 KB")
#: A calibration: `calibrate_rig` is made for 100,000 points (`wiithrow bench calibration`), whose
#: file with two cameras is 42 MB (each point's world, image, residual per camera, 208 bytes);
#: a wand or robot calibration is under 10 MB. 1.5 times the largest: loading one peaks about six
#: times the text above the process (a 42 MB file: 244 MB), so this bounds a load to ~0.4 GB.
CALIBRATION_SIZE = SizeBound(
    64 * MiB, "a calibration", "100,000 points seen by two cameras are 42 MB; thin the points of a larger one"
)
#: A throw library: at most `online.MAX_SIZE` (200) throws of 0.3 KB and a history of at most
#: `online.MAX_HISTORY` (5,000) updates of 0.4 KB and 0.5 KB per throw retired: about 7 MB with a
#: retirement per join; 32 MiB leaves four times that.
LIBRARY_SIZE = SizeBound(32 * MiB, "a throw library", "200 throws and a history of 5,000 updates are about 7 MB")
#: A training progress file: at most `training_run.MAX_THROWS` (100) throws of at most 0.6 KB
#: (measured, with what measured it), 60 KB; its notes at most 20 KB.
TRAINING_RUN_SIZE = SizeBound(4 * MiB, "a training progress file", "100 throws and their notes are under 100 KB")
#: Any other versioned JSON document read from disk (a driver check's report: 20 KB).
DOCUMENT_SIZE = SizeBound(16 * MiB, "a wiithrow document", "a driver check's report is 20 KB")


def read_text(path: str | os.PathLike[str], bound: SizeBound | None = None) -> str:
    """The UTF-8 text of `path`; `FileFormatError`, naming the file, when it is missing or cannot
    be read, and `FileTooLargeError` (one line, nothing read) when it is larger than `bound`
    (module docstring: the size from `os.fstat`, then at most `bound.max_bytes + 1` bytes read)."""
    try:
        with open(path, "rb") as handle:
            if bound is None:
                data = handle.read()
            else:
                size = os.fstat(handle.fileno()).st_size
                if size > bound.max_bytes:
                    raise bound.refusal(path, size)
                data = handle.read(bound.max_bytes + 1)
                if len(data) > bound.max_bytes:
                    raise bound.refusal(path, len(data))
        return data.decode("utf-8")
    except FileNotFoundError:
        raise FileFormatError(f"{path}: no such file") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise FileFormatError(f"{path}: cannot be read ({exc})") from None


def versioned_json_text(kind: str, schema: int, payload: dict[str, Any]) -> str:
    """`payload` as the text of a JSON document tagged with its `kind` and `schema` version."""
    return dumps_strict({"kind": kind, "schema": schema, **payload}, indent=2) + "\n"


def write_versioned_json(path: str | os.PathLike[str], kind: str, schema: int, payload: dict[str, Any]) -> Path:
    """Write `payload` as a JSON document tagged with its `kind` and `schema` version, atomically."""
    return atomic_write_text(path, versioned_json_text(kind, schema, payload))


#: How deep objects and arrays may nest in JSON we read (files and messages). Ours nest less than
#: 10 deep (a calibration's `cameras[i].world[j]` is 5, a marker's position in a message 4);
#: Python's own parser gives up near 1,000 with a `RecursionError`, and recursive code
#: (`strict_json`, the caller's) before that.
MAX_JSON_DEPTH = 32


def loads_json(text: str | bytes, source: str, *, max_depth: int = MAX_JSON_DEPTH) -> Any:
    """The JSON document in `text` (NaN and infinities read as floats, as Python's `json` does).

    `FileFormatError` "SOURCE: ..." in one line for text that is not JSON or nests objects and
    arrays deeper than `max_depth` (`json_depth`: no depth makes the check recurse)."""
    try:
        document = json.loads(text)
    except RecursionError:
        raise FileFormatError(
            f"{source}: nested deeper than {max_depth} levels (arrays or objects inside each other), "
            "which no wiithrow file or message is"
        ) from None
    except UnicodeDecodeError as exc:
        raise FileFormatError(f"{source}: not UTF-8 text ({exc.reason} at byte {exc.start})") from None
    except json.JSONDecodeError as exc:
        raise FileFormatError(f"{source}: not valid JSON (line {exc.lineno}, column {exc.colno}: {exc.msg})") from None
    if json_depth(text) > max_depth:
        raise FileFormatError(
            f"{source}: nested deeper than {max_depth} levels (arrays or objects inside each other), "
            "which no wiithrow file or message is"
        )
    return document


#: A JSON string (its escapes included) and the bytes that are not brackets, for `json_depth`.
_JSON_STRING = re.compile(rb'"[^"\\]*(?:\\.[^"\\]*)*"')
_NOT_BRACKETS = bytes(range(256)).translate(None, b"[]{}")


def json_depth(text: str | bytes) -> int:
    """How deep arrays and objects nest in the valid JSON `text` (a scalar: 0, `[]`: 1, `[[1]]`:
    2): the strings removed, the brackets' running count (+1 for `[`, `{`; -1 for `]`, `}`) at
    its highest. Done on the text at C speed (no walk of the parsed document): about a third of
    the parse's time on a 25 MB calibration, half of what a walk of the parsed document took."""
    raw = text.encode("utf-8", "surrogatepass") if isinstance(text, str) else text
    if b'"' in raw:
        raw = _JSON_STRING.sub(b"", raw)
    brackets = np.frombuffer(raw.translate(None, _NOT_BRACKETS), dtype=np.uint8)
    if brackets.size == 0:
        return 0
    steps = np.where((brackets == ord("[")) | (brackets == ord("{")), 1, -1).astype(np.int64)
    return int(np.cumsum(steps).max())


def non_finite_path(value: Any, path: str = "") -> str | None:
    """Where the first NaN or infinity in a parsed JSON `value` is, as `path` followed by keys and
    indices (`meta.fit[2]`), or None when every number is finite. An explicit stack, no recursion."""
    stack: list[tuple[Any, str]] = [(value, path)]
    while stack:
        node, where = stack.pop()
        if isinstance(node, float):
            if not math.isfinite(node):
                return where or "the value"
        elif isinstance(node, dict):
            stack.extend((child, f"{where}.{key}" if where else str(key)) for key, child in reversed(node.items()))
        elif isinstance(node, list):
            stack.extend((child, f"{where}[{i}]") for i, child in reversed(list(enumerate(node))))
    return None


def read_versioned_json(
    path: str | os.PathLike[str], kind: str, schema: int, bound: SizeBound = DOCUMENT_SIZE
) -> dict[str, Any]:
    """Read a JSON document written by `write_versioned_json`, checking its kind and schema version.

    Raises `FileFormatError`, naming the file, when it is missing, larger than `bound`
    (`FileTooLargeError`, before it is read), not JSON, nested deeper than `MAX_JSON_DEPTH`, of
    another kind or of another schema version.
    """
    path = Path(path)
    text = read_text(path, bound)
    try:
        document = loads_json(text, str(path))
    except FileFormatError as exc:
        raise FileFormatError(f"{exc}; the file is corrupt: restore it or write a new one") from None
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
