"""Whose marker frames `RemoteRig` adopts: the publisher named on the command line, or the one the
operator confirmed; every other is offered to the operator and never followed on its own.

Only signed frames reach this point (`frame_auth`: a process of this user's). A publisher is a
*source* (its Zenoh session id) and a *stream* (drawn when it starts: a restart is a new stream,
its seq and clock from 0), which every frame says. `SourcePin` judges each frame whose payload
passed (`marker_checks`), in arrival order:

* **Nothing is followed at first.** With `serve --markers-source ZENOH_ID` the first stream of that
  Zenoh id is followed at its first frame, and no other id is looked at; without it, no stream is
  followed until the operator confirms one (`adopt`: the dashboard's Marker source folder).
* **Candidates.** A stream that is not followed is refused (`other_source`) and kept as a
  candidate while its frames follow one another (seq + 1 to + `MAX_SEQ_STEP`, t up to +
  `MAX_T_STEP_S`); once it has sent `FOLLOW_FRAMES` such frames it is offered (`candidates`: its ids,
  its frames and the host, pid and command it announced, `tell_origin`) with a one-line notice,
  "... asks to be followed", once per stream. A candidate silent for `CANDIDATE_TIMEOUT_S` is no
  longer offered; at most `MAX_CANDIDATES` are kept (the stalest forgotten).
* **The followed stream**: a frame that follows the last adopted one is adopted. One that does not
  is refused (`seq`) and changes nothing of it: a frame at or below the last adopted seq is a copy
  or a late frame (a replay older than the signatures `frame_auth` remembers); one above it that
  jumps (after a pause of over `MAX_T_STEP_S`, or `MAX_SEQ_STEP` frames lost) makes the stream a
  candidate again, which the operator confirms as any other.
* **A change needs the operator.** A restarted publisher, or another stream after the followed one
  stopped, is a candidate: until the operator confirms it, the markers are stale
  (`RemoteRig.stale_reason`), which stops a motion, and the notice says who asks to be followed.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Protocol, runtime_checkable

from wiithrow.app.errors import AppError
from wiithrow.app.network.marker_checks import Refused
from wiithrow.app.network.messages import Origin

MAX_SEQ_STEP = 100  # 1 s of frames at 100 Hz (the transport is reliable: none is lost)
MAX_T_STEP_S = 10.0  # a publisher paused longer is offered to the operator again
#: Frames in order a candidate sends before it is offered: a live stream, not one stray frame.
FOLLOW_FRAMES = 10
#: A candidate silent this long (s, arrival clock) is no longer offered: it stopped.
CANDIDATE_TIMEOUT_S = 2.0
#: Candidates kept at once (every one is a process of this user's: a bound, not a filter).
MAX_CANDIDATES = 16
#: Origins and offered streams remembered (a few per candidate: restarts).
MAX_REMEMBERED = 4 * MAX_CANDIDATES

Key = tuple[str, str]


@dataclass
class Series:
    """A stream's frames in order: its last `seq` and `t`, how many followed one another, when."""

    source: str
    stream: str
    seq: int
    t: float
    first_arrival: float
    last_arrival: float
    count: int = 1

    def follows(self, seq: int, t: float) -> bool:
        return self.seq < seq <= self.seq + MAX_SEQ_STEP and self.t < t <= self.t + MAX_T_STEP_S

    def step(self, seq: int, t: float, arrival: float) -> None:
        self.seq, self.t, self.last_arrival, self.count = seq, t, arrival, self.count + 1


@dataclass(frozen=True)
class SourceCandidate:
    """A publisher as the operator is shown it: its ids, frames so far, how long ago it last sent
    (s, when asked), the origin it announced (None until it did) and whether it is the followed
    stream (offered again after a jump)."""

    source: str
    stream: str
    frames: int
    age_s: float
    origin: Origin | None
    followed: bool = False

    def describe(self) -> str:
        where = self.origin.describe() if self.origin is not None else "it has not said where it runs"
        return f"source {self.source}, stream {self.stream} ({where})"


@runtime_checkable
class ChoosesSource(Protocol):
    """A marker source whose publisher the operator chooses (`RemoteRig`)."""

    def candidates(self) -> list[SourceCandidate]: ...

    def followed(self) -> SourceCandidate | None: ...

    def adopt(self, source: str, stream: str) -> str: ...

    def source_refused(self) -> str | None: ...


class SourcePin:
    """Which publisher's frames are adopted (see the module docstring); `judge` each frame whose
    payload passed, in arrival order; `notices` collects what the operator is told."""

    def __init__(self, named_source: str | None = None) -> None:
        self.named_source = named_source
        self.pinned: Series | None = None
        self.last_adopted_arrival = -math.inf
        self.notices: list[str] = []
        self._series: dict[Key, Series] = {}
        self._origins: dict[Key, Origin] = {}
        self._offered: dict[Key, None] = {}

    def judge(self, source: str, stream: str, seq: int, t: float, arrival: float) -> str:
        """Adopt the frame (returns a notice to tell the operator first, or "") or raise Refused."""
        named = self.named_source
        if named is not None and source != named:
            raise Refused("other_source", f"source {source[:16]}, not the one named ({named[:16]})")
        key = (source, stream)
        pinned = self.pinned
        if pinned is not None and key == (pinned.source, pinned.stream):
            if pinned.follows(seq, t):
                pinned.step(seq, t, arrival)
                self.last_adopted_arrival = arrival
                self._series.pop(key, None)  # an offer of it after a jump is void: it follows again
                return ""
            if seq <= pinned.seq:
                raise Refused(
                    "seq", f"seq {seq} again or older (the last adopted is {pinned.seq}): a copy or a late frame"
                )
            self._track(key, seq, t, arrival)
            raise Refused(
                "seq",
                f"seq {seq} t {t:.3f} s does not follow seq {pinned.seq} t {pinned.t:.3f} s: the operator confirms a jump",
            )
        if pinned is None and named is not None:
            self._adopt(Series(source, stream, seq, t, arrival, arrival))
            return f"following source {source}, stream {stream} (the one named with --markers-source)"
        self._track(key, seq, t, arrival)
        followed = f"the followed {pinned.source[:16]}/{pinned.stream[:16]}" if pinned else "no stream is followed yet"
        raise Refused("other_source", f"source {source[:16]}, stream {stream[:16]} is not followed ({followed})")

    def _track(self, key: Key, seq: int, t: float, arrival: float) -> None:
        """Keep `key`'s frames as a candidate's; offer it (a notice) once FOLLOW_FRAMES followed."""
        series = self._series.get(key)
        if series is not None and series.follows(seq, t):
            series.step(seq, t, arrival)
        else:
            if series is None and len(self._series) >= MAX_CANDIDATES:
                stalest = min(self._series, key=lambda k: self._series[k].last_arrival)
                del self._series[stalest]
            series = self._series[key] = Series(key[0], key[1], seq, t, arrival, arrival)
        if series.count >= FOLLOW_FRAMES and key not in self._offered:
            self._offered[key] = None
            _forget_oldest(self._offered)
            self.notices.append(
                f"{self._candidate(series).describe()} asks to be followed: its markers are not used until the "
                "operator confirms it (the dashboard's Marker source folder)"
            )

    def tell_origin(self, source: str, stream: str, origin: Origin) -> None:
        """Where the publisher of (`source`, `stream`) says it runs (its signed announcement)."""
        self._origins[(source, stream)] = origin
        _forget_oldest(self._origins)

    def _candidate(self, series: Series, now: float | None = None) -> SourceCandidate:
        key = (series.source, series.stream)
        pinned = self.pinned
        followed = pinned is not None and key == (pinned.source, pinned.stream)
        age = 0.0 if now is None else max(0.0, now - series.last_arrival)
        return SourceCandidate(series.source, series.stream, series.count, age, self._origins.get(key), followed)

    def candidates(self, now: float) -> list[SourceCandidate]:
        """The streams offered to the operator at `now` (arrival clock), the first to come first."""
        live = [
            s for s in self._series.values() if s.count >= FOLLOW_FRAMES and now - s.last_arrival <= CANDIDATE_TIMEOUT_S
        ]
        return [self._candidate(s, now) for s in sorted(live, key=lambda s: s.first_arrival)]

    def followed(self, now: float) -> SourceCandidate | None:
        """The stream followed at `now` (None before one was)."""
        return self._candidate(self.pinned, now) if self.pinned is not None else None

    def adopt(self, source: str, stream: str, now: float) -> str:
        """Follow the candidate (`source`, `stream`) from its next frame (the operator confirmed it);
        its notice. AppError when it is not offered at `now`."""
        series = self._series.get((source, stream))
        if series is None or series.count < FOLLOW_FRAMES or now - series.last_arrival > CANDIDATE_TIMEOUT_S:
            offered = ", ".join(f"{c.source}/{c.stream}" for c in self.candidates(now)) or "none"
            raise AppError(f"source {source}, stream {stream} does not ask to be followed now (offered: {offered})")
        self._adopt(series)
        return f"following {self._candidate(series).describe()} (confirmed by the operator)"

    def _adopt(self, series: Series) -> None:
        self.pinned = Series(
            series.source, series.stream, series.seq, series.t, series.first_arrival, series.last_arrival
        )
        self.last_adopted_arrival = series.last_arrival
        self._series.pop((series.source, series.stream), None)
        self._offered.pop((series.source, series.stream), None)  # a jump of it later is offered again


def _forget_oldest(remembered: dict[Key, Any]) -> None:
    """Keep the newest MAX_REMEMBERED entries of an insertion-ordered dict."""
    while len(remembered) > MAX_REMEMBERED:
        del remembered[next(iter(remembered))]
