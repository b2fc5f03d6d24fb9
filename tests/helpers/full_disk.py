"""A disk that fills up: the binary file `StagedFile` writes into, taking `capacity` bytes and then
failing with ENOSPC as a full file system does (a short write, then the error), so that what a
full disk does to a streamed output is tested in-process, without mounting one."""

from __future__ import annotations

import errno
import io
import os


class FullDisk(io.RawIOBase):
    """A raw file on `fd` that takes `capacity` bytes, then raises OSError(ENOSPC)."""

    def __init__(self, fd: int, capacity: int) -> None:
        self._file = io.FileIO(fd, "w")
        self.room = capacity

    def writable(self) -> bool:
        return True

    def fileno(self) -> int:
        return self._file.fileno()

    def write(self, data) -> int:
        if self.room <= 0:
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))
        n = min(len(data), self.room)
        self._file.write(bytes(data[:n]))
        self.room -= n
        return n

    def close(self) -> None:
        self._file.close()
        super().close()


def fill_after(monkeypatch, capacity: int) -> None:
    """Every `StagedFile` opened from now on writes to a disk with `capacity` bytes free."""
    from wiithrow.vision import outputs

    monkeypatch.setattr(outputs, "_binary", lambda fd: io.BufferedWriter(FullDisk(fd, capacity)))
