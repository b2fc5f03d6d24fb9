"""What native libraries write to the process's standard error: `captured_stderr()`.

C and C++ libraries (urdfdom under Pinocchio, Cyclone DDS) write their own lines to file
descriptor 2, beside and before the one-line error the command prints. `captured_stderr()`
points fd 2 at a temporary file while its block runs and gives the text afterwards, so the caller
can make what the library said the detail of its own one line, or write it back when nothing
failed. Python's `sys.stderr` writes to the same descriptor, so anything printed by any thread
during the block is captured too: keep blocks to the one library call. One block at a time in a
process (a lock): a nested block would capture into the outer one's file.
"""

from __future__ import annotations

import os
import sys
import tempfile
import threading
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass

_lock = threading.RLock()


@dataclass
class Captured:
    """The text fd 2 received during a `captured_stderr()` block (set when the block ends)."""

    text: str = ""

    @property
    def lines(self) -> list[str]:
        """The non-empty lines, stripped."""
        return [line.strip() for line in self.text.splitlines() if line.strip()]

    def replay(self) -> None:
        """Write the captured text back to stderr (nothing failed: nothing is hidden)."""
        if self.text:
            sys.stderr.write(self.text)
            sys.stderr.flush()


@contextmanager
def captured_stderr() -> Iterator[Captured]:
    """Capture fd 2 while the block runs (module docstring); the text is in the yielded `Captured`
    when the block ends, whether it raised or not."""
    captured = Captured()
    with _lock, tempfile.TemporaryFile() as sink:
        sys.stderr.flush()
        saved = os.dup(2)
        os.dup2(sink.fileno(), 2)
        try:
            yield captured
        finally:
            sys.stderr.flush()
            os.dup2(saved, 2)
            os.close(saved)
            sink.seek(0)
            captured.text = sink.read().decode(errors="replace")
