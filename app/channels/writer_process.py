"""`WriterProcess`: a child process that writes what the tracking process hands it, and its loop.

Why a process: a writer in the tracking process, on its thread or one of its own, pays for its
encoding on the tracking thread or in interpreter-lock hand-overs (`bench tracking`'s frames/s
with `--ros2` or `--foxglove`: docs/performance.md). The parent packs frames into a `FrameRing`
(`records`: a few microseconds) and goes on; the child (`python -m MODULE CONFIG`, a
module that calls `run` with its sink) owns the connections (DDS participant, ...) and writes.

The parent's side (`WriterProcess`):
  - starts the child with the ring's name, slots and eventfd, and a JSON configuration; waits
    for its first stdout line, `ready` (else the child's last stderr line, in one AppError);
  - `send(message)`: a rare message (a throw) as one JSON line on the child's stdin (blocking:
    never call it from the tracking thread);
  - a watcher thread reads the child's stderr; if the child ends while it should not, `failure`
    says why in one line, told once on stderr (`on_failure`); the tracking goes on regardless (the
    ring never waits);
  - `close()`: closes the child's stdin (the child finishes what is in the ring, closes its
    connections and exits), waits `CLOSE_S`, then kills it; unlinks the ring.
No orphan: the child's stdin is a pipe only the parent holds; when the parent ends, however it
ends, the child reads EOF and exits (`serve`).

The child's side (`run`: the ring opened, the sink made from the configuration (a sink that cannot
start is its one stderr line and exit status 1), served, closed; `serve`, its loop): runs `WRITER_NICE` nicer than its parent (or as told: `nice`), sleeps on the ring's eventfd (woken only when it went to sleep:
`FrameRing.wake`, so a busy child costs the tracking thread no system call) and hands each batch of
records to `on_records`, each stdin line to `on_message`, calls `on_idle` at least every
`IDLE_S`; an exception in them is one stderr line and exit status 1.
"""

from __future__ import annotations

import json
import os
import queue
import subprocess
import sys
import threading
import time
from collections.abc import Callable
from typing import Any, Protocol

from wiithrow.app.channels.frame_ring import FrameRing
from wiithrow.app.errors import AppError

READY = "ready"
START_S = 30.0
CLOSE_S = 5.0
IDLE_S = 0.05
#: The writer's niceness above its parent's: on a busy machine the tracking gets the cores first, and a
#: writer that falls behind loses its oldest records (counted) rather than slowing the tracking down.
WRITER_NICE = 10


class WriterProcess:
    """The child `python -m module` fed by `ring` (module docstring)."""

    def __init__(
        self,
        what: str,
        module: str,
        ring: FrameRing,
        config: dict[str, Any],
        *,
        on_failure: Callable[[str], None] | None = None,
    ) -> None:
        self.what = what
        self.ring = ring
        self.failure: str | None = None
        self.on_failure = on_failure
        self._closing = False
        self._stderr: list[str] = []
        arguments = {"ring": ring.name, "slots": ring.slots, "slot_bytes": ring.slot_bytes, "wake_fd": ring.wake_fd}
        os.set_inheritable(ring.wake_fd, True)
        self.child = subprocess.Popen(
            [sys.executable, "-m", module, json.dumps({**arguments, **config})],
            stdin=subprocess.PIPE,
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
            pass_fds=(ring.wake_fd,),
        )
        # set once the start is decided (READY read, or the start given up and `_closing` set):
        # the watcher tells of an end only after it, and never of a start the constructor refused
        self._started = threading.Event()
        self._watcher = threading.Thread(target=self._watch, name=f"wiithrow-{what}-watcher", daemon=True)
        self._watcher.start()
        assert self.child.stdout is not None
        line = _readline(self.child.stdout, START_S)
        if line.strip() != READY:
            self._closing = True
            self._started.set()
            self._end()
            self._watcher.join(timeout=2.0)
            last = (self._stderr[-1] if self._stderr else line.strip()) or f"no answer within {START_S:.0f} s"
            raise AppError(f"{what}: the writer process did not start: {last}")
        self._started.set()

    @property
    def pid(self) -> int:
        return self.child.pid

    def alive(self) -> bool:
        return self.child.poll() is None

    def wait_until_read(self, timeout_s: float) -> bool:
        """Wait until the child has read (and acknowledged) every record written so far; whether it
        did within `timeout_s` (False at once when the child is gone)."""
        end = time.monotonic() + timeout_s
        while self.ring.read_seq < self.ring.written:
            if time.monotonic() >= end or not self.alive():
                return False
            time.sleep(0.001)
        return True

    def send(self, message: dict[str, Any]) -> bool:
        """One JSON line to the child; False when it is gone."""
        assert self.child.stdin is not None
        try:
            self.child.stdin.write(json.dumps(message) + "\n")
            self.child.stdin.flush()
            return True
        except (BrokenPipeError, OSError, ValueError):
            return False

    def _watch(self) -> None:
        assert self.child.stderr is not None
        for line in self.child.stderr:
            if line.strip():
                self._stderr.append(line.strip())
                del self._stderr[:-20]
        code = self.child.wait()
        self._started.wait(START_S)
        if not self._closing:
            last = self._stderr[-1] if self._stderr else "no message"
            self.failure = f"the {self.what} writer process ended (exit status {code}): {last}"
            if self.on_failure is not None:
                self.on_failure(self.failure)

    def close(self) -> None:
        """End the child after what the ring holds (module docstring), and free the ring."""
        self._closing = True
        self._end()
        self._watcher.join(timeout=2.0)
        for stream in (self.child.stdout, self.child.stderr):
            if stream is not None:
                stream.close()
        self.ring.close()

    def _end(self) -> None:
        if self.child.stdin is not None:
            try:
                self.child.stdin.close()
            except OSError:
                pass
        try:
            self.child.wait(timeout=CLOSE_S)
        except subprocess.TimeoutExpired:
            self.child.kill()
            self.child.wait()


def _readline(stream: Any, timeout_s: float) -> str:
    """A line of `stream`, or '' after `timeout_s` (a thread reads it: pipes have no timeout)."""
    lines: queue.SimpleQueue[str] = queue.SimpleQueue()
    threading.Thread(target=lambda: lines.put(stream.readline()), daemon=True).start()
    try:
        return lines.get(timeout=timeout_s)
    except queue.Empty:
        return ""


# -- the child's side


def open_ring(config: dict[str, Any]) -> FrameRing:
    return FrameRing.open(config["ring"], config["slots"], config["slot_bytes"], config["wake_fd"])


def open_back(config: dict[str, Any]) -> FrameRing:
    """The ring of the child's answers (never woken: the parent polls it)."""
    name, slots, slot_bytes = config["back"]
    return FrameRing.open(name, slots, slot_bytes, -1)


class ChildSink(Protocol):
    """What a writer process's sink does with what it is handed (`run`)."""

    def on_records(self, batch: list[bytes]) -> None: ...

    def on_message(self, message: dict[str, Any]) -> None: ...

    def on_idle(self) -> None: ...

    def close(self) -> None: ...


def run(what: str, config: dict[str, Any], open_sink: Callable[[dict[str, Any], FrameRing], ChildSink]) -> int:
    """A writer process's life (module docstring): its exit status."""
    ring = open_ring(config)
    try:
        sink = open_sink(config, ring)
    except AppError as exc:  # one line, what the parent shows (`WriterProcess`: the child's last line)
        print(exc, file=sys.stderr, flush=True)
        ring.close()
        return 1
    except Exception as exc:  # (a library that did not load)
        print(f"{what} writer: cannot start: {type(exc).__name__}: {exc}", file=sys.stderr, flush=True)
        ring.close()
        return 1
    try:
        sink.on_idle()
        return serve(
            what, ring, sink.on_records, sink.on_message, sink.on_idle, nice=int(config.get("nice", WRITER_NICE))
        )
    finally:
        sink.close()
        ring.close()


def serve(
    what: str,
    ring: FrameRing,
    on_records: Callable[[list[bytes]], None],
    on_message: Callable[[dict[str, Any]], None],
    on_idle: Callable[[], None],
    *,
    nice: int = WRITER_NICE,
) -> int:
    """The child's loop (module docstring) until its stdin closes; its exit status. `nice`: how
    much nicer than its parent it runs (a writer whose latency is the point may say 0)."""
    messages: queue.SimpleQueue[dict[str, Any] | None] = queue.SimpleQueue()
    if nice:
        os.nice(nice)

    def read_stdin() -> None:
        for line in sys.stdin:
            if line.strip():
                messages.put(json.loads(line))
        messages.put(None)  # the parent closed it, or ended
        ring.wake()

    threading.Thread(target=read_stdin, name="stdin", daemon=True).start()
    print(READY, flush=True)
    idle_at = time.monotonic()
    try:
        while True:
            ring.wait(IDLE_S)
            on_records(ring.read())
            ring.acknowledge()  # what was read is written: the writer's `flush` may return
            while True:
                try:
                    message = messages.get_nowait()
                except queue.Empty:
                    break
                if message is None:
                    on_records(ring.read())
                    ring.acknowledge()
                    return 0
                on_message(message)
            if time.monotonic() - idle_at >= IDLE_S:
                idle_at = time.monotonic()
                on_idle()
    except Exception as exc:
        print(f"{what} writer: {type(exc).__name__}: {exc}", file=sys.stderr, flush=True)
        return 1
