"""What a command prints besides its own lines, one line each: `one_line_output(command)`.

While a command runs, three channels that print several lines by default print one:

- a warning (numpy's `RuntimeWarning: overflow encountered ...`, scipy's, a library's) is not
  printed where it happens (Python's default: two lines, the file and the source line): warnings
  are counted, and a command that ends well says so in one line at its end, `wiithrow CMD: N
  warnings, the first: <Category>: <message> (<file>:<line>)`; a command that fails prints its
  one-line error only (a warning is the symptom of the bad input the error names). Only how a
  warning is shown changes: the filters decide as before, so a warning configured as an error
  (`-W error`, pytest's `filterwarnings`) still raises;
- a log record of level WARNING or above (a library's, or one of ours with its exception) is
  `wiithrow CMD: <logger>: <message>`, its exception as `<Type>: <message>` on the same line
  instead of a traceback. Installed only when nothing else handles the root logger (a test's
  capture, an application's own logging stay as they are);
- an exception that ends a thread is `wiithrow CMD: thread <name> stopped: <Type>: <message>`
  (the loops catch what they call: `wiithrow.fault_lines`; this is the net under them).

Everything is put back when the command ends (`main` runs commands in-process in the tests).
"""

from __future__ import annotations

import logging
import os
import sys
import threading
import warnings
from collections.abc import Iterator
from contextlib import contextmanager
from typing import Any, TextIO

from wiithrow.fault_lines import describe


class _OneLineHandler(logging.Handler):
    def __init__(self, command: str) -> None:
        super().__init__(logging.WARNING)
        self.command = command

    def emit(self, record: logging.LogRecord) -> None:
        try:
            text = " ".join(record.getMessage().split())
            exc = record.exc_info[1] if record.exc_info else None
            if exc is not None:
                text += f": {describe(exc)}"
            print(f"wiithrow {self.command}: {record.name}: {text}", file=sys.stderr, flush=True)
        except Exception:
            self.handleError(record)


@contextmanager
def one_line_output(command: str) -> Iterator[None]:
    """Warnings, log records and threads' exceptions as one line each while the block runs
    (module docstring)."""
    warned: list[str] = []  # the first warning's line, then a count: bounded however long the command runs
    count = 0

    def show_warning(
        message: Warning | str,
        category: type[Warning],
        filename: str,
        lineno: int,
        file: TextIO | None = None,
        line: str | None = None,
    ) -> None:
        nonlocal count
        count += 1
        if not warned:
            text = " ".join(str(message).split())
            warned.append(f"{category.__name__}: {text} ({os.path.basename(filename)}:{lineno})")

    def thread_ended(args: Any) -> None:
        if args.exc_type is SystemExit:
            return
        name = args.thread.name if args.thread is not None else "?"
        exc = args.exc_value if args.exc_value is not None else args.exc_type()
        print(f"wiithrow {command}: thread {name} stopped: {describe(exc)}", file=sys.stderr, flush=True)

    root = logging.getLogger()
    handler = _OneLineHandler(command) if not root.handlers else None
    saved_show, saved_hook = warnings.showwarning, threading.excepthook
    warnings.showwarning = show_warning
    threading.excepthook = thread_ended
    if handler is not None:
        root.addHandler(handler)
    try:
        yield
        if warned:
            how_many = f"{count} warning" + ("s, the first" if count > 1 else "")
            print(f"wiithrow {command}: {how_many}: {warned[0]}", file=sys.stderr, flush=True)
    finally:
        warnings.showwarning = saved_show
        threading.excepthook = saved_hook
        if handler is not None:
            root.removeHandler(handler)
