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

Every markers sample passes the checks of `wiithrow.app.network.marker_checks` before it is
adopted: its payload (schema, rig name, finite values, a visible marker inside the rig's
calibrated volume: the view of the settings' nominal cameras, `volume_Ps`), its sender (the
pinned source and stream, `named_source` or the first accepted; a restart followed after a
notice), its `seq` and `t` (they follow), and its freshness on this host's arrival clock (a late
frame or a burst is stale). A refused frame is counted by reason (`refused`), never kept; the
operator is told through `notices` (one line each: whom it follows, a restart, and a summary of
the refusals at most every `NOTICE_EVERY_S`). `stale_reason()` says why the markers may not move
the arm now (no fresh frame for `SILENT_S`, or a frame of the pinned source refused within it),
which a motion checks every tick (`wiithrow.app.alignment.aligner`). The arrival clock is the
Unix time of Zenoh's callback (`Subscription`); in a simulated loopback (`source` given: the
world's clock stands still while its frames cross) it is the rig's clock when the frame is read.

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
from collections import Counter, deque
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np
from numpy.typing import NDArray

from wiithrow.app.errors import AppError
from wiithrow.app.network.marker_checks import (
    REASONS,
    SILENT_S,
    Freshness,
    MarkerVolume,
    Refused,
    SourcePin,
    check_identity,
    check_markers_message,
)
from wiithrow.app.network.messages import tracked_frame
from wiithrow.app.network.subscriber import Received, Subscription, key_expression
from wiithrow.app.rig.events import Flushed, FramesProcessed, RigEvent, RigListener
from wiithrow.app.rig.kept_frames import KeptFrames
from wiithrow.app.rig.source import MarkerSource
from wiithrow.clock import Clock
from wiithrow.listeners import Listeners, Unsubscribe, batch
from wiithrow.vision.sync import SyncedFrame
from wiithrow.vision.tracked_frame import TrackedFrame
from wiithrow.vision.wiimote.frames import IRFrame
from wiithrow.vision.wiimote.protocol import Button

#: The refusals are summed up for the operator at most this often (s, arrival clock).
NOTICE_EVERY_S = 5.0
#: A payload longer than this is refused unread (a frame of four markers is under 1 kB).
MAX_PAYLOAD_BYTES = 16 * 1024


class RemoteRig(KeptFrames):
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
        named_source: str | None = None,
        volume_Ps: NDArray[np.float64] | None = None,
    ) -> None:
        self.prefix = key_expression(prefix.rstrip("/"))
        self.rig_name = self.prefix.rsplit("/", 1)[-1]
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
        self._last_local_t = -float("inf")
        self.volume = MarkerVolume(np.asarray(Ps if volume_Ps is None else volume_Ps, dtype=float))
        self.pin = SourcePin(named_source)
        self.freshness = Freshness()
        self.adopted = 0
        self._from_source = 0  # frames that name the pinned (or named) source: what `settle_s` waits for
        self.refused: Counter[str] = Counter()
        self.dots_refused = 0
        self.notices: Listeners[str] = Listeners(f"the notices of {self.prefix}")
        self._pending_notices: list[str] = []
        self._refused_since_notice: Counter[str] = Counter()
        self._first_refusal = ""
        self._last_notice = -float("inf")
        self._last_fresh_arrival: float | None = None
        self._pinned_failure: tuple[float, str] | None = None
        self._last_stale: tuple[float, str] | None = None
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
        by the source's lock, as a local rig's poll (the rig loop and an operation both poll); its
        events are one batch (`wiithrow.listeners.batch`), as a local rig's poll's."""
        with batch(), self._lock:
            if self.source is not None:
                self._expected += self.source()
            out: list[TrackedFrame] = []
            end = time.monotonic() + max(timeout_s, self.settle_s)
            while True:
                sample = self._markers.get(0.0)
                if sample is None:
                    if self._from_source >= self._expected or time.monotonic() >= end:
                        break
                    time.sleep(0.0002)
                    continue
                self.received += 1
                frame = self._take(sample)
                if frame is not None:
                    out.append(frame)
            # what did not come back within settle_s is given up on (lost, or late: it is taken
            # when it comes): a frame missing once must not make every later poll wait settle_s
            self._expected = self._from_source
            out = self._restamp(out)
            self._read_dots()
            self.tracked.extend(out)
            self._summarise_refusals()
            if out and self.events:
                self.events.emit(Flushed(self.clock.now(), len(out), out))
            notices, self._pending_notices = self._pending_notices, []
        for notice in notices:  # outside the lock: a listener may read the rig
            self.notices.emit(notice)

    def _arrival(self, sample: Received) -> float:
        """When `sample` arrived, on the arrival clock (see the module docstring)."""
        return self.clock.now() if self.source is not None else sample.received

    def arrival_now(self) -> float:
        return self.clock.now() if self.source is not None else time.time()

    def _take(self, sample: Received) -> TrackedFrame | None:
        """The sample's frame if it passes every check (marker_checks), else None (counted)."""
        arrival = self._arrival(sample)
        source = None
        try:
            if len(sample.payload) > MAX_PAYLOAD_BYTES:
                raise Refused("malformed", f"a payload of {len(sample.payload)} bytes")
            message = sample.decode()
            source, stream = check_identity(message, self.rig_name)
            if source == (self.pin.named_source or (self.pin.pinned and self.pin.pinned.source)):
                self._from_source += 1
            check_markers_message(message, self.volume)
            seq, t = int(message["seq"]), float(message["t"])
            notice = self.pin.judge(source, stream, seq, t, arrival)
        except Refused as refused:
            self._refuse(refused, arrival, from_pinned=self._is_pinned(source))
            return None
        except Exception as exc:  # a payload the checks did not foresee: refused too, never raised into a motion
            self._refuse(Refused("malformed", f"{type(exc).__name__}: {exc}"[:200]), arrival, from_pinned=False)
            return None
        if notice:
            self._tell(f"markers from {self.prefix}: {notice}")
            self.freshness.restart()
        self.adopted += 1
        self.latencies_s.append(sample.received - float(message["sent"]))
        stale = self.freshness.judge(t, arrival)
        if stale is not None:
            self._last_stale = (arrival, stale)
            self._refuse(Refused("stale", stale), arrival, from_pinned=False)
            return None
        self._last_fresh_arrival = arrival
        return tracked_frame(message)

    def _is_pinned(self, source: str | None) -> bool:
        pinned = self.pin.pinned
        return source is not None and pinned is not None and source == pinned.source

    def _refuse(self, refused: Refused, arrival: float, *, from_pinned: bool) -> None:
        self.refused[refused.reason] += 1
        self._refused_since_notice[refused.reason] += 1
        if not self._first_refusal:
            self._first_refusal = f"{refused.reason}: {refused.detail}"
        if from_pinned and refused.reason != "other_source":  # the pinned publisher sent a bad frame
            self._pinned_failure = (arrival, f"{refused.reason}: {refused.detail}")

    def _tell(self, notice: str) -> None:
        self._pending_notices.append(notice)

    def _summarise_refusals(self) -> None:
        """One line for the refusals since the last one, at most every NOTICE_EVERY_S."""
        now = self.arrival_now()
        if not self._refused_since_notice or now - self._last_notice < NOTICE_EVERY_S:
            return
        counts = ", ".join(f"{self._refused_since_notice[r]} {r}" for r in REASONS if self._refused_since_notice[r])
        total = sum(self._refused_since_notice.values())
        self._tell(f"markers from {self.prefix}: refused {total} frames ({counts}); first: {self._first_refusal}")
        self._refused_since_notice.clear()
        self._first_refusal = ""
        self._last_notice = now

    def stale_reason(self) -> str | None:
        """Why the markers may not move the arm now (one line), or None while they are fresh: no
        fresh frame adopted for `SILENT_S` (the publisher stopped, its frames are late, a burst, or
        refused), or a frame of the pinned source refused within it."""
        now = self.arrival_now()
        with self._lock:
            failure, stale, last = self._pinned_failure, self._last_stale, self._last_fresh_arrival
        if failure is not None and now - failure[0] <= SILENT_S:
            return f"a marker frame from {self.prefix} failed validation ({failure[1]})"
        if last is None:
            return f"no fresh marker frame from {self.prefix} yet"
        if now - last > SILENT_S:
            why = f" (stale: {stale[1]})" if stale is not None and stale[0] >= last else ""
            return f"no fresh marker frame from {self.prefix} for {now - last:.2f} s{why}"
        return None

    def refusal_counts(self) -> str:
        """The refusals so far, e.g. "3 other_source, 1 malformed" ("none")."""
        text = ", ".join(f"{self.refused[r]} {r}" for r in REASONS if self.refused[r])
        return text or "none"

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
        """Each camera's dots (what the dashboard draws), from the pinned source only."""
        while (sample := self._dots.get(0.0)) is not None:
            message = sample.decode() if len(sample.payload) <= MAX_PAYLOAD_BYTES else None
            dots = _dots(message, len(self._history))
            pinned = self.pin.pinned
            if (
                dots is None
                or pinned is None
                or not isinstance(message, dict)
                or message.get("source") != pinned.source
            ):
                self.dots_refused += 1
                continue
            camera = int(message["camera"])
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

    def synced_since(self, t: float) -> list[SyncedFrame]:
        """None: the far host synchronises (a wand calibration is refused here anyway)."""
        return []


def _dots(message: Any, cameras: int) -> NDArray[np.float64] | None:
    """A dots payload's four pixels (NaN for null), or None when it is not one of a known camera."""
    if not isinstance(message, dict):
        return None
    camera, seq, dots = message.get("camera"), message.get("seq"), message.get("dots")
    if not isinstance(camera, int) or not 0 <= camera < cameras or not isinstance(seq, int):
        return None
    if not isinstance(dots, list) or len(dots) != 4:
        return None
    out = np.full((4, 2), np.nan)
    for i, d in enumerate(dots):
        if d is None:
            continue
        if not isinstance(d, list) or len(d) != 2 or not all(isinstance(x, (int, float)) for x in d):
            return None
        if not (0 <= d[0] <= 1023 and 0 <= d[1] <= 767):
            return None
        out[i] = d
    return out
