"""Where a command's outputs go, checked before the work starts, and written all or none.

A command that works for a minute and then cannot write its result has lost that minute, and one
that writes the first of two files and then fails leaves half an output. So:

* `check_output_file(path, replace=...)` runs before any work: it refuses, with one clear line
  (`OutputPathError`), a path that is a folder or not a regular file, a path under a file, a
  folder that cannot be written (read-only file system, no permission: probed by creating and
  removing a file there, which is what the write will do), and an existing file the user did not
  ask to replace (`replace=False`). Missing parent folders are fine: they are created when the
  files are written.
* `OutputFiles` stages several files and `commit()` writes them: every file first goes to a
  temporary file beside its destination (`files.write_temp_beside`: fsync'ed, the mode the
  destination will have); only when all of them are written are they renamed into place. If a
  rename fails (or the run is interrupted) the renames already made are undone (the previous
  files come back from hard links taken before), so the destinations hold the old files or the
  new ones, all of them. Folders created for the outputs are removed again on failure.
* `StagedFile`: one file written as a stream of lines (`wiithrow track --out`), into a temporary
  file that `commit()` renames into place. When a write fails part-way (a full disk: ENOSPC, a
  quota, an I/O error) the lines written until then are not lost: the temporary file is cut after
  its last complete line and renamed into place, and the write raises `OutputWriteError` saying
  how many lines were kept, one line for the user. A file that cannot be written at all (the
  disk is full before the work starts) was refused by `check_output_file`'s probe, or keeps no
  line.
* A whole folder of outputs (`wiithrow reproduce`) is written into `new_staging_folder(dest)`, a
  hidden sibling of `dest`, and swapped in by `replace_folder` when complete: an interrupted run
  leaves the old folder as it was.
"""

from __future__ import annotations

import contextlib
import errno
import io
import os
import secrets
import shutil
from pathlib import Path
from typing import BinaryIO, NoReturn

from wiithrow.vision.errors import OutputPathError, OutputWriteError
from wiithrow.vision.files import Content, create_temp_beside, sync_folder, write_temp_beside


def _existing_ancestor(path: Path) -> Path:
    """The nearest existing folder at or above `path`'s parent; OutputPathError when it is a file."""
    parent = path.parent
    while not parent.exists():
        if parent == parent.parent:
            break
        parent = parent.parent
    if not parent.is_dir():
        raise OutputPathError(f"cannot write {path}: {parent} is a file, not a folder")
    return parent


def _probe(folder: Path, path: Path) -> None:
    """Create and remove a file in `folder`: OutputPathError, saying why, when that fails."""
    probe = folder / f".wiithrow-probe-{secrets.token_hex(4)}"
    try:
        fd = os.open(probe, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o600)
    except OSError as exc:
        reason = "a read-only file system" if exc.errno == errno.EROFS else (exc.strerror or str(exc)).lower()
        raise OutputPathError(f"cannot write {path}: folder {folder} is not writable ({reason})") from None
    os.close(fd)
    probe.unlink()


def check_output_file(path: str | os.PathLike[str], *, replace: bool = True, hint: str = "") -> Path:
    """Check, before any work, that `path` can be written (module docstring); return it.

    `replace=False`: an existing file is refused (the user did not name it); `hint` ends that
    message ("PATH exists and HINT", e.g. "--out does not name it: pass --force to replace it"). A symbolic link is followed: its
    target is what gets written.
    """
    path = Path(path)
    if str(path) in ("", "."):
        raise OutputPathError("an output file needs a name")
    if path.is_symlink():
        path = Path(os.path.realpath(path))
    if path.exists():
        if path.is_dir():
            raise OutputPathError(f"cannot write {path}: it is a folder; give a file name")
        if not path.is_file():
            raise OutputPathError(f"cannot write {path}: it is not a regular file")
        if not replace:
            raise OutputPathError(f"{path} exists and " + (hint or "would be replaced"))
    _probe(_existing_ancestor(path), path)
    return path


def check_output_folder(path: str | os.PathLike[str]) -> Path:
    """Check, before any work, that a folder of outputs can be made at `path` (it is a folder or
    absent, and its parent can be written); return it."""
    path = Path(path)
    if path.exists() and not path.is_dir():
        raise OutputPathError(f"cannot write into {path}: it is a file, not a folder")
    _probe(_existing_ancestor(path), path)
    return path


class OutputFiles:
    """Files written together, all or none (module docstring)."""

    def __init__(self) -> None:
        self._files: list[tuple[Path, Content]] = []

    def add(self, path: str | os.PathLike[str], data: str | Content) -> OutputFiles:
        """Stage `data` for `path`: text (written as UTF-8), bytes, or a function that writes the
        text to an open handle when the files are written (`files.Content`)."""
        self._files.append((Path(path), data.encode("utf-8") if isinstance(data, str) else data))
        return self

    def __len__(self) -> int:
        return len(self._files)

    def commit(self) -> list[Path]:
        """Write every staged file (module docstring); return their paths."""
        made: list[Path] = []
        temps: list[tuple[Path, Path]] = []
        renamed: list[tuple[Path, Path | None]] = []
        try:
            for path, data in self._files:
                made += _make_parents(path.parent)
                temps.append((write_temp_beside(path, data), path))
            for tmp, path in temps:
                backup = _hard_link_beside(path) if path.exists() else None
                try:
                    os.replace(tmp, path)
                except BaseException:
                    if backup is not None:
                        backup.unlink(missing_ok=True)
                    raise
                renamed.append((path, backup))
        except BaseException:
            for path, backup in reversed(renamed):
                with contextlib.suppress(OSError):
                    if backup is not None:
                        os.replace(backup, path)
                    else:
                        path.unlink()
            for tmp, _ in temps:
                tmp.unlink(missing_ok=True)
            for folder in reversed(made):
                with contextlib.suppress(OSError):
                    folder.rmdir()
            raise
        for _, backup in renamed:
            if backup is not None:
                backup.unlink(missing_ok=True)
        for folder in {path.parent for path, _ in self._files}:
            sync_folder(folder)
        return [path for path, _ in self._files]


class StagedFile:
    """A text file written as a stream of lines (`handle`) into a temporary file beside `path`:
    `commit()` renames it over `path`, `discard()` removes it (and the folders made for it). A
    reader of `path` sees the old file or the whole new one; or, when a write failed part-way
    (module docstring), the complete lines written until then, and the failing write or commit
    raised `OutputWriteError` (then `discard()` does nothing)."""

    def __init__(self, path: str | os.PathLike[str]) -> None:
        self.path = Path(path)
        self._made = _make_parents(self.path.parent)
        fd, self._tmp = create_temp_beside(self.path)
        self._state = "open"  # then "failing" (keeping what was written), "committed", "discarded" or "kept"
        self.handle = _StagedText(_binary(fd), self)

    def commit(self) -> Path:
        try:
            self.handle.flush()
            os.fsync(self.handle.fileno())
        except OSError as exc:
            raise self._keep_written(exc) from None
        self.handle.close()
        os.replace(self._tmp, self.path)
        sync_folder(self.path.parent)
        self._state = "committed"
        return self.path

    def discard(self) -> None:
        if self._state != "open":
            return
        self._state = "discarded"
        self.handle.close()
        self._tmp.unlink(missing_ok=True)
        for folder in reversed(self._made):
            with contextlib.suppress(OSError):
                folder.rmdir()

    def _keep_written(self, exc: OSError) -> OutputWriteError:
        """After a failed write: close the file, cut it after its last complete line, rename it
        into place; the error that says so."""
        self._state = "failing"
        with contextlib.suppress(OSError, ValueError):  # the buffer's rest cannot be written either
            self.handle.close()
        reason = exc.strerror or str(exc)
        try:
            lines = _cut_after_last_line(self._tmp)
            os.replace(self._tmp, self.path)
            sync_folder(self.path.parent)
        except OSError as second:
            self._state = "kept"
            return OutputWriteError(
                f"cannot write {self.path} ({reason}), nor keep what was written in it "
                f"({second.strerror or second}): what was written is in {self._tmp}"
            )
        self._state = "kept"
        return OutputWriteError(
            f"cannot write more to {self.path} ({reason}): the {lines} complete lines written until then are kept in it"
        )


class _StagedText(io.TextIOWrapper):
    """A `StagedFile`'s handle: UTF-8 text whose failed writes keep what was written
    (`StagedFile._keep_written`) and raise `OutputWriteError`."""

    def __init__(self, binary: BinaryIO, staged: StagedFile) -> None:
        super().__init__(binary, encoding="utf-8", newline="")
        self._staged = staged

    def write(self, text: str) -> int:
        try:
            return super().write(text)
        except OSError as exc:
            self._fail(exc)

    def flush(self) -> None:
        try:
            super().flush()
        except OSError as exc:
            self._fail(exc)

    def _fail(self, exc: OSError) -> NoReturn:
        if self._staged._state != "open":  # closing after the failure: the caller ignores it
            raise exc
        raise self._staged._keep_written(exc) from None


def _binary(fd: int) -> BinaryIO:
    """A buffered binary file on `fd` (tests replace it with one whose disk fills up)."""
    return os.fdopen(fd, "wb")


def _cut_after_last_line(path: Path) -> int:
    """Truncate `path` just after its last newline (a partly written last line goes); the number
    of lines kept. Reads the file once, in blocks; truncating needs no free space."""
    lines = 0
    end = 0
    offset = 0
    with open(path, "rb+") as file:
        while block := file.read(1 << 20):
            count = block.count(b"\n")
            if count:
                lines += count
                end = offset + block.rindex(b"\n") + 1
            offset += len(block)
        file.truncate(end)
        file.flush()
        with contextlib.suppress(OSError):
            os.fsync(file.fileno())
    return lines


def _make_parents(folder: Path) -> list[Path]:
    """Create `folder` and its missing parents; return the ones created, outermost first."""
    missing = []
    while not folder.exists():
        missing.append(folder)
        folder = folder.parent
    for created in reversed(missing):
        created.mkdir()
    return list(reversed(missing))


def _hard_link_beside(path: Path) -> Path | None:
    """A hard link to `path` under a temporary name (the old file, should the commit be undone);
    None where the file system has no hard links (then a failed commit cannot bring it back)."""
    link = path.with_name(f".{path.name}.{secrets.token_hex(4)}.old")
    try:
        os.link(path, link)
    except OSError:
        return None
    return link


def new_staging_folder(dest: str | os.PathLike[str]) -> Path:
    """A new, empty, hidden sibling of `dest` to write a folder of outputs into (mode 0777 less the
    umask, or `dest`'s own when it exists)."""
    dest = Path(dest)
    dest.parent.mkdir(parents=True, exist_ok=True)
    while True:
        staging = dest.with_name(f".{dest.name}.{secrets.token_hex(4)}.tmp")
        try:
            staging.mkdir(0o777)
            break
        except FileExistsError:
            continue
    if dest.is_dir():
        staging.chmod(dest.stat().st_mode & 0o7777)
    return staging


def replace_folder(staging: str | os.PathLike[str], dest: str | os.PathLike[str]) -> Path:
    """Put the finished folder `staging` at `dest`: the old folder (if any) is renamed aside, the
    new one renamed in, then the old one removed; if the second rename fails the old folder is
    put back."""
    staging, dest = Path(staging), Path(dest)
    if not dest.exists():
        os.rename(staging, dest)
        sync_folder(dest.parent)
        return dest
    old = dest.with_name(f".{dest.name}.{secrets.token_hex(4)}.old")
    os.rename(dest, old)
    try:
        os.rename(staging, dest)
    except BaseException:
        os.rename(old, dest)
        raise
    sync_folder(dest.parent)
    shutil.rmtree(old, ignore_errors=True)
    return dest


def remove_staging_folder(staging: str | os.PathLike[str]) -> None:
    """Remove a staging folder that will not be swapped in (the run failed)."""
    shutil.rmtree(staging, ignore_errors=True)
