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

Every sample is signed with the user's secret (`frame_auth`) and checked in Zenoh's callback
before it is queued: an unsigned, forged or replayed one is counted (`unauthenticated`,
`replayed`) and never read. Each queue is bounded (`MAX_QUEUED_MARKERS`, `MAX_QUEUED_DOTS`: a
full queue drops its oldest, counted as `queue_full`), and a poll takes at most
`MAX_MARKERS_PER_POLL` marker samples and `MAX_DOTS_PER_POLL` dots samples, and stops taking them
after `POLL_BUDGET_S`: the rest waits for the next poll, so a flood never holds the rig's lock
beyond one period of the rig loop (10 ms).

Every markers sample then passes the checks of `wiithrow.app.network.marker_checks` before it is
adopted: its payload (schema, rig name, finite values, a visible marker inside the rig's
calibrated volume: the view of the settings' nominal cameras, `volume_Ps`), its sender (the
source named with `named_source`, or the one the operator confirmed, `adopt`: the others are
offered as `candidates`, with the host, pid and command they announce on `<prefix>/publisher`,
`wiithrow.app.network.source_pin`), its `seq` and `t` (they follow), and its freshness on this
host's arrival clock (a late frame or a burst is stale). A refused frame is counted by reason
(`refused`), never kept; the operator is told through `notices` (one line each: whom it follows,
who asks to be followed, the markers turning stale and fresh again, and a summary of the refusals
at most every `remote_notices.NOTICE_EVERY_S`). `stale_reason()` says why the markers may not move the arm now
(no source followed; no fresh frame for `SILENT_S`; or a frame of the followed stream that failed
a check of its data within it: a copy of its frames, refused as `seq`, never marks it failed),
which a motion checks every tick (`wiithrow.app.alignment.aligner`); `source_refused()` says why
an operation that reads the markers may not start (no source followed). The arrival clock is the
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
from wiithrow.app.network.frame_auth import FrameVerifier, load_secret
from wiithrow.app.network.marker_checks import (
    SILENT_S,
    Freshness,
    MarkerVolume,
    Refused,
    check_identity,
    check_markers_message,
)
from wiithrow.app.network.messages import dots_of, origin_of, tracked_frame
from wiithrow.app.network.remote_notices import RemoteNotices
from wiithrow.app.network.source_pin import SourceCandidate, SourcePin
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

#: A payload longer than this is refused unread (a frame of four markers is under 1 kB).
MAX_PAYLOAD_BYTES = 16 * 1024
#: Marker samples kept for the next poll: 10 s of frames at 100 Hz, more than the catch-up of a
#: publisher paused that long (whose frames are stale anyway); about 1.5 MB of the largest.
MAX_QUEUED_MARKERS = 1000
#: Camera samples kept: 2.5 s of four remotes at 100 Hz (they are drawn, never acted on).
MAX_QUEUED_DOTS = 1000
#: Announcements kept (one a second per publisher).
MAX_QUEUED_ORIGINS = 64
#: Samples one poll takes at most: a marker sample costs about 0.1 ms to check (`bench publish`'s
#: check_p99_us), so 50 are about 5 ms, half the rig loop's 10 ms period, and 50 times the rate
#: of a publisher; a catch-up of 2 s of frames is taken in four polls.
MAX_MARKERS_PER_POLL = 50
MAX_DOTS_PER_POLL = 100
MAX_ORIGINS_PER_POLL = 8
#: A poll stops taking samples after this long (s, monotonic): one sample more at most, so the
#: rig's lock is held well within a period of the rig loop on a machine that is not preempting it.
POLL_BUDGET_S = 0.005
#: What each refusal made before the queue means, for the operator's summary.
BEFORE_THE_QUEUE = {
    "unauthenticated": "no valid signature of this user's secret: another user's process, or a forged frame",
    "replayed": "a copy of a signed frame already received",
    "malformed": f"a payload over {MAX_PAYLOAD_BYTES} bytes",
    "queue_full": f"the oldest of more than {MAX_QUEUED_MARKERS} waiting frames dropped",
}


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
        self.received = 0  # marker samples that arrived: taken, refused before the queue or dropped from it
        self.last_poll_taken = 0  # marker samples the last poll took from its queue
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
        self.told = RemoteNotices(self.prefix, MAX_QUEUED_MARKERS)
        self.refused: Counter[str] = self.told.refused  # by reason
        self.dots_refused = 0
        self.notices: Listeners[str] = Listeners(f"the notices of {self.prefix}")
        self._last_fresh_arrival: float | None = None
        self._pinned_failure: tuple[float, str] | None = None
        self._last_stale: tuple[float, str] | None = None
        self._told_stale = False
        self._no_source_said = self._no_source(self.arrival_now())  # what `source_refused` says
        secret = load_secret()  # AppError, one line, for a bad secret file
        self._markers = self._subscribe(zenoh_session, "markers", MAX_QUEUED_MARKERS, secret)
        self._dots = self._subscribe(zenoh_session, "cameras/*/dots", MAX_QUEUED_DOTS, secret)
        self._origins = self._subscribe(zenoh_session, "publisher", MAX_QUEUED_ORIGINS, secret)

    def _subscribe(self, zenoh_session: Any, key: str, max_queued: int, secret: bytes) -> Subscription:
        verifier = FrameVerifier(secret)  # one per key: each remembers its own signatures
        return Subscription(
            zenoh_session,
            f"{self.prefix}/{key}",
            max_queued=max_queued,
            verifier=verifier,
            max_payload_bytes=MAX_PAYLOAD_BYTES,
        )

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
        self._origins.close()
        if self.local is not None:
            self.local.close()

    # -- receiving ---------------------------------------------------------------------------------

    def poll(self, timeout_s: float = 0.0) -> None:
        """Take the frames that arrived since the last poll (after running `source`), at most
        `MAX_MARKERS_PER_POLL` and for `POLL_BUDGET_S` (the rest at the next poll); serialised by
        the source's lock, as a local rig's poll (the rig loop and an operation both poll); its
        events are one batch (`wiithrow.listeners.batch`), as a local rig's poll's."""
        with batch(), self._lock:
            start = time.monotonic()
            budget_end = start + POLL_BUDGET_S
            if self.source is not None:
                self._expected += self.source()
            self._read_origins()
            out: list[TrackedFrame] = []
            end = start + max(timeout_s, self.settle_s)
            taken = 0
            while taken < MAX_MARKERS_PER_POLL:
                sample = self._markers.get(0.0)
                if sample is None:
                    if self._from_source >= self._expected or time.monotonic() >= end:
                        break
                    time.sleep(0.0002)
                    continue
                taken += 1
                frame = self._take(sample)
                if frame is not None:
                    out.append(frame)
                if self.source is None and time.monotonic() >= budget_end:
                    break  # the rest at the next poll: the lock is the rig loop's too
            self.last_poll_taken = taken
            # what did not come back within settle_s is given up on (lost, or late: it is taken
            # when it comes): a frame missing once must not make every later poll wait settle_s
            self._expected = self._from_source
            out = self._restamp(out)
            self._read_dots(budget_end)
            self._count_before_the_queue()
            self.tracked.extend(out)
            self.told.summarise(self.arrival_now())
            self._watch_staleness()
            if self.pin.pinned is None:
                self._no_source_said = self._no_source(self.arrival_now())
            if out and self.events:
                self.events.emit(Flushed(self.clock.now(), len(out), out))
            notices = self.told.take()
        for notice in notices:  # outside the lock: a listener may read the rig
            self.notices.emit(notice)

    def _count_before_the_queue(self) -> None:
        """Add what the subscriptions refused or dropped before their queues to the counts."""
        markers = self._markers.take_counts()
        self.received += markers.arrived
        for reason, count in markers.refused.items():
            self.told.count(reason, count, BEFORE_THE_QUEUE.get(reason, reason))
        if markers.dropped:
            self.told.count("queue_full", markers.dropped, BEFORE_THE_QUEUE["queue_full"])
        for other in (self._dots.take_counts(), self._origins.take_counts()):
            self.dots_refused += other.refused.total() + other.dropped

    def _arrival(self, sample: Received) -> float:
        """When `sample` arrived, on the arrival clock (see the module docstring)."""
        return self.clock.now() if self.source is not None else sample.received

    def arrival_now(self) -> float:
        return self.clock.now() if self.source is not None else time.time()

    def _take(self, sample: Received) -> TrackedFrame | None:
        """The sample's frame if it passes every check (marker_checks), else None (counted)."""
        arrival = self._arrival(sample)
        source = stream = None
        try:
            message = sample.decode()
            source, stream = check_identity(message, self.rig_name)
            if source == (self.pin.named_source or (self.pin.pinned and self.pin.pinned.source)):
                self._from_source += 1
            check_markers_message(message, self.volume)
            seq, t = int(message["seq"]), float(message["t"])
            notice = self.pin.judge(source, stream, seq, t, arrival)
        except Refused as refused:
            self._refuse(refused, arrival, from_pinned=self._is_pinned(source, stream))
            return None
        except Exception as exc:  # a payload the checks did not foresee: refused too, never raised into a motion
            self._refuse(Refused("malformed", f"{type(exc).__name__}: {exc}"[:200]), arrival, from_pinned=False)
            return None
        finally:
            self._take_pin_notices()
        if notice:
            self.told.tell(f"markers from {self.prefix}: {notice}")
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

    def _is_pinned(self, source: str | None, stream: str | None = None) -> bool:
        pinned = self.pin.pinned
        return source is not None and pinned is not None and (source, stream) == (pinned.source, pinned.stream)

    def _take_pin_notices(self) -> None:
        for notice in self.pin.notices:
            self.told.tell(f"markers from {self.prefix}: {notice}")
        self.pin.notices.clear()

    def _refuse(self, refused: Refused, arrival: float, *, from_pinned: bool) -> None:
        waiting = refused.reason == "other_source" and self.pin.pinned is None  # for the operator, not refused
        self.told.count(refused.reason, 1, refused.detail, summarised=not waiting)
        # the followed publisher sent a frame whose data failed a check: the markers are suspect.
        # A frame out of order is not that: a copy of its frames (or a late one) changes nothing.
        if from_pinned and refused.reason not in ("other_source", "seq"):
            self._pinned_failure = (arrival, f"{refused.reason}: {refused.detail}")

    def stale_reason(self) -> str | None:
        """Why the markers may not move the arm now (one line), or None while they are fresh: no
        source followed yet; no fresh frame adopted for `SILENT_S` (the publisher stopped, its
        frames are late, a burst, or refused: then who asks to be followed instead, if anyone);
        or a frame of the followed stream whose data failed a check within it."""
        now = self.arrival_now()
        with self._lock:
            failure, stale, last = self._pinned_failure, self._last_stale, self._last_fresh_arrival
            if self.pin.pinned is None:
                return self._no_source(now)
            asking = self.pin.candidates(now)
        if failure is not None and now - failure[0] <= SILENT_S:
            return f"a marker frame from {self.prefix} failed validation ({failure[1]})"
        if last is None:
            return f"no fresh marker frame from {self.prefix} yet"
        if now - last > SILENT_S:
            why = f" (stale: {stale[1]})" if stale is not None and stale[0] >= last else ""
            asks = f"; {asking[0].describe()} asks to be followed: confirm it on the dashboard" if asking else ""
            return f"no fresh marker frame from {self.prefix} for {now - last:.2f} s{why}{asks}"
        return None

    def _no_source(self, now: float) -> str:
        """Why nothing is followed yet (the caller holds the lock)."""
        named = self.pin.named_source
        if named is not None:
            return f"no marker source followed yet: waiting for the publisher named with --markers-source ({named})"
        offered = self.pin.candidates(now)
        if offered:
            return (
                f"no marker source followed yet: {offered[0].describe()}"
                + (f" and {len(offered) - 1} more ask" if len(offered) > 1 else " asks")
                + " to be followed: confirm one on the dashboard (Marker source)"
            )
        return (
            f"no marker source followed yet: no publisher of this user's sends under {self.prefix} "
            "(`wiithrow track --publish` on the tracking host, then confirm it on the dashboard)"
        )

    def source_refused(self) -> str | None:
        """Why an operation that reads the markers may not start: no source followed (None once one
        is), as the last poll saw it. Never waits for the rig's lock: the session asks under its own."""
        return None if self.pin.pinned is not None else self._no_source_said

    def candidates(self) -> list[SourceCandidate]:
        """The publishers that ask to be followed now (`source_pin.SourcePin.candidates`)."""
        with self._lock:
            return self.pin.candidates(self.arrival_now())

    def followed(self) -> SourceCandidate | None:
        """The publisher followed now (None before the operator confirmed one or the named one sent)."""
        with self._lock:
            return self.pin.followed(self.arrival_now())

    def adopt(self, source: str, stream: str) -> str:
        """Follow the candidate (`source`, `stream`) from its next frame: the operator confirmed it
        (AppError when it does not ask to be followed now); the notice told."""
        with self._lock:
            notice = self.pin.adopt(source, stream, self.arrival_now())
            self.freshness.restart()
            self._pinned_failure = None
            self.told.tell(f"markers from {self.prefix}: {notice}")
            notices = self.told.take()
        for line in notices:
            self.notices.emit(line)
        return notice

    def _watch_staleness(self) -> None:
        """Tell the operator when the followed markers turn stale, and when they are fresh again."""
        if self.pin.pinned is None or self._last_fresh_arrival is None:
            return
        reason = self.stale_reason()
        if reason is not None and not self._told_stale:
            self._told_stale = True
            self.told.tell(f"markers from {self.prefix} are stale: {reason}; the arm does not move on them")
        elif reason is None and self._told_stale:
            self._told_stale = False
            self.told.tell(f"markers from {self.prefix} are fresh again")

    def refusal_counts(self) -> str:
        """The refusals so far, e.g. "3 other_source, 1 malformed" ("none")."""
        return self.told.counts()

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

    def _read_dots(self, budget_end: float) -> None:
        """Each camera's dots (what the dashboard draws), from the followed stream only; at most
        MAX_DOTS_PER_POLL, and none after `budget_end` (monotonic) but in a simulated loopback."""
        pinned = self.pin.pinned
        for _ in range(MAX_DOTS_PER_POLL):
            if self.source is None and time.monotonic() >= budget_end:
                return
            sample = self._dots.get(0.0)
            if sample is None:
                return
            message = sample.decode()
            dots = dots_of(message, len(self._history))
            if (
                dots is None
                or pinned is None
                or not isinstance(message, dict)
                or (message.get("source"), message.get("stream")) != (pinned.source, pinned.stream)
            ):
                self.dots_refused += 1
                continue
            camera = int(message["camera"])
            now = self.clock.now()
            frame = IRFrame(now, now, int(message["seq"]), 0x33, dots, np.full(4, np.nan), Button(0))
            self._history[camera].append(frame)
            if self.events:
                self.events.emit(FramesProcessed(camera, [frame], []))

    def _read_origins(self) -> None:
        """Where the publishers say they run (their signed announcements), for the candidates."""
        for _ in range(MAX_ORIGINS_PER_POLL):
            sample = self._origins.get(0.0)
            if sample is None:
                return
            message = sample.decode()
            origin = origin_of(message)
            try:
                source, stream = check_identity(message, self.rig_name)
            except Refused:
                origin = None
            if origin is None:
                self.dots_refused += 1
                continue
            self.pin.tell_origin(source, stream, origin)

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
