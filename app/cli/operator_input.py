"""The operator's answers at the terminal: lines read from stdin (a terminal or a pipe), with what
was typed or piped before a question discarded.

Owns `OperatorInput`. A command that asks the operator something whose answer must come after an
event (an Enter that says "the marker is down" must come after the ball came down) calls
`discard_pending()` just before it shows the question: on a terminal the kernel's input queue is
flushed (`termios.tcflush(TCIFLUSH)`: type-ahead, a key pressed twice), on a pipe what is already
in it is read and dropped (at most `DISCARD_LIMIT_BYTES`, for a writer that never stops). The line
read next is the question's answer: only a line written after the question was shown. A script that
pipes its answers therefore writes each one after it has read the question (as an operator does);
answers piped all at once ahead are discarded, and the input's end then stops what asked (the run
is kept: `wiithrow train` says how to resume it).

Lines are read from the file descriptor itself (`os.read`, never through `sys.stdin`'s buffer, which
would hold lines ahead where nothing can discard them), a line at a time: what follows a line in one
read waits in `pending` until the next question discards it. `wait_line(step)` looks for a line
without blocking and calls `step()` between looks (the rig is read meanwhile: remotes left unread
for seconds overflow their reports' buffers). A stdin without a file descriptor (a test's stand-in)
is read with its `readline`, nothing discarded.
"""

from __future__ import annotations

import contextlib
import os
import select
import sys
import termios
from collections.abc import Callable
from typing import TextIO

#: The most (bytes) one `discard_pending` drops from a pipe: a writer that never stops (`yes ''`)
#: cannot keep it reading; an operator's type-ahead is a few bytes.
DISCARD_LIMIT_BYTES = 1 << 20
#: How long (s) `wait_line` blocks in one look when it has no `step` to call between looks: short
#: enough that Ctrl-C is answered at once.
LOOK_S = 0.1
#: The longest line (bytes) kept: a longer one is an answer to nothing (a file piped in by mistake).
MAX_LINE_BYTES = 4096


class OperatorInput:
    """Lines from the operator on file descriptor `fd` (module docstring), or from `stream`'s
    `readline` when it has none."""

    def __init__(self, fd: int | None, stream: TextIO | None = None) -> None:
        self.fd = fd
        self.stream = stream
        self.pending = b""  # read past the last line given out: dropped by the next discard
        self.ended = False

    @classmethod
    def from_stdin(cls) -> OperatorInput:
        """The process's stdin: its file descriptor when it has one, else its `readline`."""
        stream = sys.stdin
        try:
            fd = stream.fileno() if stream is not None else None
        except (OSError, ValueError, AttributeError):
            fd = None
        return cls(fd, stream)

    @property
    def is_terminal(self) -> bool:
        return self.fd is not None and os.isatty(self.fd)

    def discard_pending(self) -> int:
        """Drop what was typed or piped and not yet read as an answer (module docstring); the bytes dropped."""
        dropped = len(self.pending)
        self.pending = b""
        if self.fd is None or self.ended:
            return dropped
        if os.isatty(self.fd):
            with contextlib.suppress(termios.error):
                termios.tcflush(self.fd, termios.TCIFLUSH)
        while dropped < DISCARD_LIMIT_BYTES and self._readable(0.0):
            chunk = os.read(self.fd, 65536)
            if not chunk:
                self.ended = True
                break
            dropped += len(chunk)
        return dropped

    def wait_line(self, step: Callable[[], None] | None = None) -> str | None:
        """The next line (without its end), None at the end of input. Between looks `step()` is
        called (it lets time pass: the caller reads the rig); without it each look blocks `LOOK_S`."""
        if self.fd is None:
            read = self.stream.readline() if self.stream is not None else ""
            return read.rstrip("\r\n") if read else None
        while True:
            line = self._take_line()
            if line is not None:
                return line
            if self.ended:
                return None
            if self._readable(0.0 if step is not None else LOOK_S):
                chunk = os.read(self.fd, 65536)
                if not chunk:
                    self.ended = True
                    continue
                self.pending += chunk
                if b"\n" not in self.pending and len(self.pending) > MAX_LINE_BYTES:
                    self.pending = self.pending[-MAX_LINE_BYTES:]
            elif step is not None:
                step()

    def _take_line(self) -> str | None:
        if b"\n" not in self.pending:
            if self.ended and self.pending:  # a last line without its end
                line, self.pending = self.pending, b""
                return line.decode("utf-8", "replace").rstrip("\r")
            return None
        line, self.pending = self.pending.split(b"\n", 1)
        return line[:MAX_LINE_BYTES].decode("utf-8", "replace").rstrip("\r")

    def _readable(self, timeout_s: float) -> bool:
        assert self.fd is not None
        return bool(select.select([self.fd], [], [], timeout_s)[0])
