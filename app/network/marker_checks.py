"""The checks a published marker frame passes before `RemoteRig` adopts it.

A sample meets them after its signature (`frame_auth`, checked in `Subscription`'s callback: an
unsigned or forged frame is `unauthenticated`, a copy of a signed one `replayed`, both unread), in
this order (the numbers of the first and the last here):

* `check_markers_message(message, rig, volume)`: the payload itself. It is refused as
  `malformed` when it is not a JSON object of the `messages` markers schema (schema 1, a `seq`
  integer >= 0, finite `t` and `sent`, `frame` "link1", a non-empty `source` and `stream` of at
  most 64 characters, at most `MAX_MARKERS` markers each with an integer `id`, three coordinates
  per vector, a boolean `visible`, 0-8 `views`), as `other_rig` when its `rig` is not the one
  subscribed to, as `non_finite` when a coordinate is NaN or infinite (a JSON `NaN` or
  `Infinity`; `null` is the schema's "not a number" and is allowed except in a visible marker's
  position) or a speed is above `MAX_SPEED_M_S`, and as `out_of_volume` when a visible marker lies
  outside the rig's calibrated volume (`MarkerVolume`).
* who sent it: only the publisher named or confirmed by the operator is adopted, its frames in
  order (`source_pin.SourcePin`: `other_source`, `seq`).
* `Freshness`: whether an adopted frame is fresh, on this host's arrival clock. A frame is
  `late` when its arrival minus its publisher time `t` exceeds the smallest such offset over the
  last `OFFSET_WINDOW_S` by more than `LATE_S` (the two clocks' offset cancels; what is left is
  how much later than the fastest recent frame it came), and part of a `burst` when it and the
  `BURST_FRAMES` - 1 frames before it arrived within less than half the time the publisher took
  to track them, less `BURST_SLACK_S` (after a SIGSTOP of 5 s, 93 frames tracked over 5.3 s came
  within 0.3 s). Such frames are stale: counted, never kept for motion. No fresh frame for
  `SILENT_S` makes the markers stale too (`RemoteRig.stale_reason`), which stops a motion.

The source and stream are what the publisher says of itself; the signature (`frame_auth`) is what
makes them a process of this user's: a frame that copies them without the secret is refused
before it is read, and one of the user's own processes copying them is kept out by the seq and t
that must follow.
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass
from typing import Any, Protocol, runtime_checkable

import numpy as np
from numpy.typing import NDArray

from wiithrow.app.network.messages import SCHEMA

#: Why a frame is refused, in the order the counters are shown: before the queue (`Subscription`:
#: its signature, its size, a full queue's oldest dropped), then its payload, its sender, its freshness.
REASONS = (
    "unauthenticated",
    "replayed",
    "queue_full",
    "malformed",
    "other_rig",
    "other_source",
    "seq",
    "non_finite",
    "out_of_volume",
    "stale",
)

MAX_MARKERS = 16  # the tracker tracks four; room for a rig of more targets
MAX_ID_LENGTH = 64
MAX_SPEED_M_S = 50.0  # a thrown ball leaves at under 10 m/s
OFFSET_WINDOW_S = 10.0
LATE_S = 0.1
BURST_FRAMES = 10
BURST_SLACK_S = 0.02
SILENT_S = 0.1  # ten frames at 100 Hz

#: The calibrated volume: the depth range in front of a camera (m) and how far beyond the image's
#: edges (a fraction of its size) a marker may project, seen by at least `VOLUME_VIEWS` cameras.
NEAR_M = 0.3
FAR_M = 4.0
IMAGE_MARGIN = 0.1
IMAGE_SIZE = (1024.0, 768.0)
VOLUME_VIEWS = 2


@runtime_checkable
class ReportsStaleness(Protocol):
    """A marker source that can say its markers may not move the arm now (`RemoteRig`)."""

    def stale_reason(self) -> str | None: ...


class Refused(Exception):
    """A frame refused: `reason` (one of `REASONS`) and a one-line `detail`."""

    def __init__(self, reason: str, detail: str) -> None:
        super().__init__(f"{reason}: {detail}")
        self.reason = reason
        self.detail = detail


@dataclass(frozen=True)
class MarkerVolume:
    """The rig's calibrated volume in link1: the points at `NEAR_M` to `FAR_M` in front of at
    least `VOLUME_VIEWS` of the cameras (projection matrices `Ps`, (C, 3, 4), P = K [R | t]: the
    third row gives the depth) that project inside those cameras' images enlarged by
    `IMAGE_MARGIN` on every side. Not a box around the view: a box would let through points far
    beside it (a marker at 70 degrees beside the rig swung joint 1 by 1.2 rad more)."""

    Ps: NDArray[np.float64]

    def contains(self, points: NDArray[np.float64]) -> NDArray[np.bool_]:
        """Which of `points` (N, 3), finite, lie in the volume."""
        if len(points) == 0:
            return np.zeros(0, dtype=bool)
        h = np.einsum("cij,nj->cni", self.Ps, np.hstack([points, np.ones((len(points), 1))]))
        depth = h[..., 2]
        with np.errstate(divide="ignore", invalid="ignore"):
            u, v = h[..., 0] / depth, h[..., 1] / depth
        w, hgt = IMAGE_SIZE
        inside = (
            (depth >= NEAR_M)
            & (depth <= FAR_M)
            & (u >= -IMAGE_MARGIN * w)
            & (u <= (1 + IMAGE_MARGIN) * w)
            & (v >= -IMAGE_MARGIN * hgt)
            & (v <= (1 + IMAGE_MARGIN) * hgt)
        )
        return np.asarray(inside.sum(axis=0) >= min(VOLUME_VIEWS, len(self.Ps)))

    def describe(self) -> str:
        return (
            f"{NEAR_M:g}-{FAR_M:g} m in front of {VOLUME_VIEWS} cameras, within {100 * IMAGE_MARGIN:.0f} % "
            "of their images"
        )


def _number(x: Any) -> bool:
    return isinstance(x, (int, float)) and not isinstance(x, bool)


def _identifier(message: dict[str, Any], name: str) -> str:
    value = message.get(name)
    if not isinstance(value, str) or not 0 < len(value) <= MAX_ID_LENGTH:
        raise Refused("malformed", f"{name!r} is not a string of 1-{MAX_ID_LENGTH} characters")
    return value


def check_identity(message: Any, rig: str) -> tuple[str, str]:
    """(source, stream) of a markers payload that is an object of this schema for `rig`; else Refused."""
    if not isinstance(message, dict):
        raise Refused("malformed", f"not a JSON object ({type(message).__name__})")
    if message.get("schema") != SCHEMA:
        raise Refused("malformed", f"schema {message.get('schema')!r}, this version reads {SCHEMA}")
    if message.get("rig") != rig:
        raise Refused("other_rig", f"rig {str(message.get('rig'))[:40]!r}, not {rig!r}")
    return _identifier(message, "source"), _identifier(message, "stream")


def check_markers_message(message: dict[str, Any], volume: MarkerVolume) -> None:
    """The rest of a markers payload whose identity passed (see the module docstring); Refused if bad."""
    seq, t, sent = message.get("seq"), message.get("t"), message.get("sent")
    if not isinstance(seq, int) or isinstance(seq, bool) or seq < 0:
        raise Refused("malformed", f"seq {str(seq)[:20]!r} is not an integer >= 0")
    if not isinstance(t, (int, float)) or not isinstance(sent, (int, float)) or not (_number(t) and _number(sent)):
        raise Refused("malformed", "t or sent is not a number")
    if not (math.isfinite(t) and math.isfinite(sent)):
        raise Refused("non_finite", "t or sent is not finite")
    if message.get("frame") != "link1":
        raise Refused("malformed", f"frame {str(message.get('frame'))[:20]!r}, not 'link1'")
    markers = message.get("markers")
    if not isinstance(markers, list) or len(markers) > MAX_MARKERS:
        raise Refused("malformed", f"markers is not a list of at most {MAX_MARKERS}")
    visible_positions = []
    for m in markers:
        if not isinstance(m, dict):
            raise Refused("malformed", "a marker is not an object")
        if not isinstance(m.get("id"), int) or not isinstance(m.get("visible"), bool):
            raise Refused("malformed", "a marker's id or visible is missing")
        views = m.get("views")
        if not isinstance(views, int) or not 0 <= views <= 8:
            raise Refused("malformed", "a marker's views is not 0-8")
        for name in ("position", "velocity", "filtered"):
            vector = m.get(name)
            if not isinstance(vector, list) or len(vector) != 3:
                raise Refused("malformed", f"a marker's {name} is not three coordinates")
            for x in vector:
                if x is None:
                    continue
                if not _number(x):
                    raise Refused("malformed", f"a marker's {name} holds {str(x)[:20]!r}")
                if not math.isfinite(x):
                    raise Refused("non_finite", f"a marker's {name} holds {x!r}")
        velocity = [x for x in m["velocity"] if x is not None]
        if math.hypot(*velocity) > MAX_SPEED_M_S:
            raise Refused("non_finite", f"a marker's speed is over {MAX_SPEED_M_S:g} m/s")
        if m["visible"]:
            if any(x is None for x in m["position"]):
                raise Refused("non_finite", "a visible marker has no position")
            visible_positions.append(m["position"])
    if visible_positions:
        points = np.array(visible_positions, dtype=float)
        inside = volume.contains(points)
        if not inside.all():
            p = points[~inside][0]
            raise Refused(
                "out_of_volume",
                f"a marker at ({p[0]:.2f}, {p[1]:.2f}, {p[2]:.2f}) m in link1, outside the rig's view "
                f"({volume.describe()})",
            )


class Freshness:
    """Whether adopted frames are fresh on this host's arrival clock (see the module docstring)."""

    def __init__(self) -> None:
        self._offsets: deque[tuple[float, float]] = deque()  # (arrival, offset), offsets increasing
        self._recent: deque[tuple[float, float]] = deque(maxlen=BURST_FRAMES)  # (t, arrival)

    def restart(self) -> None:
        """A new series: its clock is another one."""
        self._offsets.clear()
        self._recent.clear()

    def judge(self, t: float, arrival: float) -> str | None:
        """Why the frame (publisher time t, arrival on this host) is stale, or None when fresh."""
        offset = arrival - t
        offsets = self._offsets
        while offsets and offsets[-1][1] >= offset:  # a monotonic queue: its head is the window's minimum
            offsets.pop()
        offsets.append((arrival, offset))
        while offsets[0][0] < arrival - OFFSET_WINDOW_S:
            offsets.popleft()
        self._recent.append((t, arrival))
        late = offset - offsets[0][1]
        if late > LATE_S:
            return f"it came {late:.2f} s later than the fastest frame of the last {OFFSET_WINDOW_S:g} s"
        if len(self._recent) == BURST_FRAMES:
            tracked_over = t - self._recent[0][0]
            arrived_within = arrival - self._recent[0][1]
            if arrived_within < tracked_over / 2 - BURST_SLACK_S:
                return (
                    f"a burst: {BURST_FRAMES} frames tracked over {tracked_over:.2f} s arrived within "
                    f"{arrived_within:.3f} s"
                )
        return None
