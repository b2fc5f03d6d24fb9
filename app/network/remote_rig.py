"""The markers another host tracks, received over Zenoh: `RemoteRig` (`serve --markers-from`).

`RemoteRig` is the `wiithrow.app.rig.source.MarkerSource` of a rig whose remotes are on another
host: `poll()` drains a `Subscription` of `<prefix>/markers` and `<prefix>/cameras/*/dots` (what
`track --publish`, `demo --publish` or `serve --publish` put, `messages`), keeps the frames (the
tracked frames, each camera's recent dots) and tells its listeners (`FramesProcessed` per camera
of dots, `Flushed` with the tracked frames that came), so the session, the alignment, the throw
and the dashboard read it exactly as a local rig. It tracks nothing itself and has no driver.
Each frame is restamped with this host's clock when it is read (the publisher's clock is another
machine's): the newest frame of a poll at the time of reading, the others spaced as the far host
tracked them, strictly increasing. `latencies_s` holds, per marker frame, arrival - `sent` (Unix
times of two hosts: as good as their clocks' synchronisation, NTP or PTP; exact on one machine).

Its calibration is the far host's (`Ps`, revision 1): `set_calibration` is refused, saying where
to calibrate.

`source`: a callable run at the start of every `poll` (the simulated world's own rig and
publisher, so that a simulation closes the loop through Zenoh: `local` is that rig, which
`connect` and `close` open and close); with `settle_s`, `poll` waits that long at most for every
frame `source` said it published to come back.
"""

from __future__ import annotations

import dataclasses
import threading
import time
from collections import deque
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np
from numpy.typing import NDArray

from wiithrow.app.errors import AppError
from wiithrow.app.network.messages import tracked_frame
from wiithrow.app.network.subscriber import Subscription, key_expression
from wiithrow.app.rig.events import Flushed, FramesProcessed, RigEvent, RigListener
from wiithrow.app.rig.source import MarkerSource
from wiithrow.clock import Clock
from wiithrow.listeners import Listeners, Unsubscribe
from wiithrow.vision.sync import SyncedFrame
from wiithrow.vision.tracker import TrackedFrame
from wiithrow.vision.wiimote.frames import IRFrame
from wiithrow.vision.wiimote.protocol import Button


class RemoteRig:
    """The markers of `prefix` (e.g. `wiithrow/lab`) received on `zenoh_session` (see the module docstring)."""

    def __init__(
        self,
        zenoh_session: Any,
        prefix: str,
        camera_names: Sequence[str],
        Ps: NDArray[np.float64],
        clock: Clock,
        *,
        source: Callable[[], int] | None = None,
        settle_s: float = 0.0,
        local: MarkerSource | None = None,
        history: int = 100,
    ) -> None:
        self.prefix = key_expression(prefix.rstrip("/"))
        self.clock = clock
        self._camera_names = list(camera_names)
        self._Ps = np.asarray(Ps, dtype=float)
        self.source = source
        self.local = local
        self.settle_s = settle_s
        self.received = 0
        self.latencies_s: deque[float] = deque(maxlen=100_000)
        self.tracked: deque[TrackedFrame] = deque(maxlen=10 * history)
        self._history: list[deque[IRFrame]] = [deque(maxlen=history) for _ in self._camera_names]
        self._lock = threading.RLock()
        self.events: Listeners[RigEvent] = Listeners(f"the markers from {self.prefix}")
        self._expected = 0
        self._last_remote_t = -float("inf")
        self._last_local_t = -float("inf")
        self._markers = Subscription(zenoh_session, f"{self.prefix}/markers")
        self._dots = Subscription(zenoh_session, f"{self.prefix}/cameras/*/dots")

    # -- what the source is ------------------------------------------------------------------------

    @property
    def camera_names(self) -> list[str]:
        return list(self._camera_names)

    @property
    def Ps(self) -> NDArray[np.float64]:
        """The far host's calibration, as this host knows it."""
        return self._Ps

    @property
    def calibrated(self) -> bool:
        return True

    @property
    def calibration_revision(self) -> int:
        return 1

    @property
    def lock(self) -> threading.RLock:
        return self._lock

    def subscribe(self, listener: RigListener) -> Unsubscribe:
        return self.events.subscribe(listener)

    def calibration_refused(self) -> str:
        return f"the markers come from {self.prefix}: calibrate the rig on the host that tracks it"

    def set_calibration(self, Ps: NDArray[np.float64]) -> None:
        raise AppError(self.calibration_refused())

    def connect(self) -> None:
        """Nothing to open here (the remotes are the far host's), but `local`'s remotes."""
        if self.local is not None:
            self.local.connect()

    def close(self) -> None:
        self._markers.close()
        self._dots.close()
        if self.local is not None:
            self.local.close()

    # -- receiving ---------------------------------------------------------------------------------

    def poll(self, timeout_s: float = 0.0) -> None:
        """Take the frames that arrived since the last poll (after running `source`); serialised
        by the source's lock, as a local rig's poll (the rig loop and an operation both poll)."""
        with self._lock:
            if self.source is not None:
                self._expected += self.source()
            out: list[TrackedFrame] = []
            end = time.monotonic() + max(timeout_s, self.settle_s)
            while True:
                sample = self._markers.get(0.0)
                if sample is None:
                    if self.received >= self._expected or time.monotonic() >= end:
                        break
                    time.sleep(0.0002)
                    continue
                message = sample.decode()
                frame = tracked_frame(message)
                self.received += 1
                self.latencies_s.append(sample.received - float(message["sent"]))
                if frame.t <= self._last_remote_t:  # out of order: a local rig never goes back in time
                    continue
                self._last_remote_t = frame.t
                out.append(frame)
            out = self._restamp(out)
            self._read_dots()
            self.tracked.extend(out)
            if out and self.events:
                self.events.emit(Flushed(self.clock.now(), len(out), out))

    def _restamp(self, frames: list[TrackedFrame]) -> list[TrackedFrame]:
        """The frames on this clock: the newest at now, the others as far before it as they were
        tracked before it on the far host, and never at or before a frame already kept."""
        if not frames:
            return frames
        now = self.clock.now()
        newest = frames[-1].t
        out = []
        for frame in frames:
            t = max(now - (newest - frame.t), self._last_local_t + 1e-6)
            self._last_local_t = t
            out.append(dataclasses.replace(frame, t=t))
        return out

    def _read_dots(self) -> None:
        while (sample := self._dots.get(0.0)) is not None:
            message = sample.decode()
            camera = int(message.get("camera", -1))
            if not 0 <= camera < len(self._history):
                continue
            dots = np.array([[np.nan, np.nan] if d is None else d for d in message["dots"]], dtype=float)
            now = self.clock.now()
            frame = IRFrame(now, now, int(message["seq"]), 0x33, dots, np.full(4, np.nan), Button(0))
            self._history[camera].append(frame)
            if self.events:
                self.events.emit(FramesProcessed(camera, [frame], []))

    def latency_ms(self) -> dict[str, float]:
        """p50, p99 and max of arrival - sent over the frames received (ms; empty before any)."""
        if not self.latencies_s:
            return {}
        lat = 1e3 * np.array(self.latencies_s)
        return {
            "p50_ms": float(np.percentile(lat, 50)),
            "p99_ms": float(np.percentile(lat, 99)),
            "max_ms": float(lat.max()),
        }

    # -- reading what was kept ----------------------------------------------------------------------

    @property
    def latest(self) -> list[IRFrame | None]:
        with self._lock:
            return [h[-1] if h else None for h in self._history]

    def recent(self, camera: int, count: int) -> list[IRFrame]:
        with self._lock:
            return list(self._history[camera])[-count:]

    def tracked_since(self, t: float) -> list[TrackedFrame]:
        with self._lock:
            return [f for f in self.tracked if f.t > t]

    def synced_since(self, t: float) -> list[SyncedFrame]:
        """None: the far host synchronises (a wand calibration is refused here anyway)."""
        return []

    def latest_tracked(self) -> TrackedFrame | None:
        with self._lock:
            return self.tracked[-1] if self.tracked else None

    def latest_dots(self) -> NDArray[np.float64]:
        return np.stack([f.dots if f is not None else np.full((4, 2), np.nan) for f in self.latest])
