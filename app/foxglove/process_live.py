"""`FoxgloveProcessLive`: Foxglove live for a rig, its server and encoding in a writer process.

What `track --foxglove` and `bench tracking --foxglove` run. In-process (`FoxgloveLive`), the
events' JSON encoding runs on a thread of the tracking process and takes the interpreter lock
from the tracking thread. Here the rig's events are packed, on the thread that tells them, into a
`FrameRing` (`frame_records`: each event's raw reports, dots and tracked frames, then its `END`),
and a child (`writer_main`, started by `WriterProcess`) owns foxglove-sdk's server and a
`Recorder` whose writes go to it: the same channels, schemas and messages as `FoxgloveLive`.

While no client is subscribed (the child tells: `WATCHED`, every ~50 ms) an event is not packed
(`unwatched()`; calibrations excepted). A slow or stopped child never stalls the rig: the ring
overwrites, the child counts the records it lost (`dropped()`), and a child that ends is one line
on stderr (`failure`).
"""

from __future__ import annotations

import sys
import threading
from typing import TYPE_CHECKING, Any

from wiithrow.app.foxglove.server import DEFAULT_PORT, LOOPBACK, check_host
from wiithrow.app.network import frame_records as records
from wiithrow.app.network.frame_ring import FrameRing
from wiithrow.app.network.writer_process import WriterProcess
from wiithrow.app.rig.events import CalibrationChanged, Flushed, FramesProcessed, ReportsRead, RigEvent

if TYPE_CHECKING:  # annotations only: the writer process imports this module for its constants
    from wiithrow.app.rig.pipeline import TrackingPipeline
    from wiithrow.app.rig.source import MarkerSource

RING_SLOTS = 8192
#: The child's figures in the ring's header (`FrameRing.report`).
PORT, WATCHED, LOGGED = 3, 4, 5


def _says_nothing(event: RigEvent) -> bool:
    """An event the `Recorder` writes nothing for (no frames processed, none synced, no report):
    not packed. (A poll that finds nothing new still tells its events: polled every millisecond,
    as a simulated world's `pump` does, 9 in 10 of a camera's `FramesProcessed` and every `Flushed`
    said nothing, measured on the session's 2-camera rig.)"""
    if isinstance(event, FramesProcessed):
        return not event.frames
    if isinstance(event, Flushed):
        return not event.synced
    if isinstance(event, ReportsRead):
        return not event.batch
    return False


class FoxgloveProcessLive:
    """A rig's channels, live, on `host`:`port` (0: a free one), served by a writer process, until
    `close()` (module docstring; `host` beyond loopback only with `insecure_network`)."""

    def __init__(
        self,
        rig: TrackingPipeline | MarkerSource,
        *,
        port: int = DEFAULT_PORT,
        frame_id: str = "link1",
        host: str = LOOPBACK,
        insecure_network: bool = False,
        command: str = "foxglove",
        session: bool = False,
    ) -> None:
        check_host(host, insecure_network=insecure_network)
        self.host = host
        self.clock = rig.clock
        self._unwatched = 0
        self._lock = threading.Lock()  # one event's records at a time
        self.ring = FrameRing.create(RING_SLOTS, records.SLOT_BYTES)
        config = {
            "port": port,
            "host": host,
            "frame_id": frame_id,
            "cameras": len(rig.camera_names),
            "session": session,  # a session's channels too (`FoxgloveSessionProcessLive`)
        }

        def tell(failure: str) -> None:
            print(f"wiithrow {command}: {failure}; tracking goes on without Foxglove", file=sys.stderr, flush=True)

        try:
            self.process = WriterProcess(
                "Foxglove", "wiithrow.app.foxglove.writer_main", self.ring, config, on_failure=tell
            )
        except BaseException:
            self.ring.close()
            raise
        self.port = self.ring.figure(PORT)
        self._rig = rig
        with rig.lock:  # between two polls: every event from now on
            if rig.Ps is not None:
                self._calibrated(rig.Ps)
            self._unsubscribe = rig.subscribe(self._event)

    def url(self) -> str:
        host = f"[{self.host}]" if ":" in self.host else self.host
        return f"ws://{host}:{self.port}"

    def _calibrated(self, Ps: Any) -> None:
        with self._lock:
            if not self.ring.closed:
                records.put_calibration(self.ring, Ps)
                records.put_end(self.ring, records.CALIBRATED, now=self.clock.now())
                self.ring.wake()

    def _event(self, event: RigEvent) -> None:
        """One event of the rig, packed (on the rig's thread, under its lock; never raises into it)."""
        if isinstance(event, CalibrationChanged):
            self._calibrated(event.Ps)
            return
        if not self.ring.figure(WATCHED):
            self._unwatched += 1
            return
        if _says_nothing(event):
            return
        ring = self.ring
        with self._lock:
            if ring.closed:
                return
            if isinstance(event, FramesProcessed):
                for frame in event.frames:
                    records.put_dots(ring, event.camera, frame, 0)
                for tracked in event.tracked:
                    records.put_markers(ring, 0, tracked, 0)
                records.put_end(ring, records.PROCESSED, event.camera)
                self._processed(event)
            elif isinstance(event, Flushed):
                for tracked in event.tracked:
                    records.put_markers(ring, 0, tracked, 0)
                records.put_end(ring, records.FLUSHED, now=event.now, synced=event.synced)
            elif isinstance(event, ReportsRead):
                for t, data in event.batch:
                    records.put_report(ring, event.camera, t, data)
                records.put_end(ring, records.REPORTS, event.camera)
            ring.wake()

    def _processed(self, event: FramesProcessed) -> None:
        """After a camera's frames were packed (under the lock, on the rig's thread): what a
        subclass adds (a session's arm)."""

    @property
    def failure(self) -> str | None:
        return self.process.failure

    def logged(self) -> int:
        """Messages logged so far, to a client subscribed to their channel (the child's count)."""
        return self.ring.figure(LOGGED)

    def dropped(self) -> int:
        """Records the child lost: the ring came round before it read them."""
        return self.ring.dropped

    def unwatched(self) -> int:
        """Rig events skipped: no client was subscribed to anything."""
        return self._unwatched

    def flush(self, timeout_s: float = 2.0) -> bool:
        """Wait until the child has read every record so far; whether it did in time."""
        return self.process.wait_until_read(timeout_s)

    def close(self) -> None:
        self._unsubscribe()
        self.flush(1.0)
        with self._lock:
            self.process.close()
