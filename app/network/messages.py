"""The key expressions and payloads wiithrow publishes over Zenoh (docs/integrations/zenoh.md).

Every payload is one strict JSON object (UTF-8, encoding `application/json`) with `"schema": 1`,
the rig's name and who sent it (`Sender`): `source`, the publisher's Zenoh session id (hex), and
`stream`, a random id drawn when the publisher starts (a restart is a new stream, its `seq` and
clock from 0; `wiithrow.app.network.marker_checks` pins and follows them). Under `wiithrow/<rig>/`:

* `markers`: one tracked frame: `seq` (0, 1, ... per publisher, in order), `t` (s, the rig's
  clock), `sent` (Unix time when it was published), `frame` (the calibration's frame, `link1`),
  `markers`: a list of {`id`, `position`, `velocity`, `filtered` (m, m/s), `visible`, `views`}.
* `cameras/<name>/dots`: one camera frame: `seq`, `camera` (its index), `t` (the remote's send
  time on the rig's clock), `sent`, `dots`: four [u, v] pixels or null for an empty slot.
* `throws`: one executed throw: `seq`, `sent`, `index` and `result` (`ThrowRecord.to_dict`).
* `publisher`: who publishes, said before its first marker frame and every `ANNOUNCE_EVERY_S`
  after (`wiithrow.app.channels.zenoh_sink`): `seq`, `sent`, and its `Origin`: `host` (the host's
  name), `pid` (the process the operator started) and `command` (its command line, the value of a
  `--token` left out): what the operator is shown before following a source.

Every sample is signed with the user's secret (its attachment: `wiithrow.app.network.frame_auth`).

A rig name is one key-expression chunk: letters, digits, `-`, `_` and `.`.
"""

from __future__ import annotations

import math
import os
import re
import secrets
import socket
import sys
import time
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from wiithrow.app.errors import AppError
from wiithrow.vision.files import dumps_strict
from wiithrow.vision.tracked_frame import TrackedFrame
from wiithrow.vision.wiimote.frames import IRFrame

SCHEMA = 1
PREFIX = "wiithrow"
DEFAULT_RIG = "rig"
_CHUNK = re.compile(r"^[A-Za-z0-9_.-]+$")


def rig_name(text: str) -> str:
    """`text` if it is a usable rig name (one key-expression chunk), else AppError."""
    if not _CHUNK.match(text):
        raise AppError(f"a rig name is letters, digits, '-', '_' and '.', got {text!r}")
    return text


def rig_prefix(rig: str) -> str:
    return f"{PREFIX}/{rig}"


def markers_key(rig: str) -> str:
    return f"{rig_prefix(rig)}/markers"


def dots_key(rig: str, camera: str) -> str:
    """A camera's key; characters a key chunk cannot hold become '_'."""
    return f"{rig_prefix(rig)}/cameras/{re.sub(r'[^A-Za-z0-9_.-]', '_', camera) or '_'}/dots"


def throws_key(rig: str) -> str:
    return f"{rig_prefix(rig)}/throws"


def publisher_key(rig: str) -> str:
    return f"{rig_prefix(rig)}/publisher"


#: The longest host name and command line an announcement holds (characters).
MAX_HOST_LENGTH = 255
MAX_COMMAND_LENGTH = 300
_SECRET_FLAGS = ("--token",)


@dataclass(frozen=True)
class Origin:
    """Where a publisher runs: `host` (its name), `pid`, `command` (its command line)."""

    host: str
    pid: int
    command: str

    @classmethod
    def of_this_process(cls) -> Origin:
        return cls(socket.gethostname(), os.getpid(), command_line(getattr(sys, "orig_argv", sys.argv)))

    def fields(self) -> dict[str, Any]:
        return {"host": self.host, "pid": self.pid, "command": self.command}

    def describe(self) -> str:
        return f"host {self.host}, pid {self.pid}: {self.command}"


def command_line(argv: Sequence[str]) -> str:
    """`argv` as one line of printable characters (each run of white space or control characters
    one space): the program's file name without its folder, a `--token`'s value left out, at most
    `MAX_COMMAND_LENGTH` characters."""
    words = [os.path.basename(argv[0])] if argv else []
    hide = False
    for word in argv[1:]:
        if hide:
            words.append("...")
            hide = False
            continue
        name = word.split("=", 1)[0]
        if name in _SECRET_FLAGS:
            hide = "=" not in word
            words.append(f"{name}=..." if "=" in word else word)
            continue
        words.append(word)
    text = "".join(c if c.isprintable() else " " for c in " ".join(words))
    text = " ".join(text.split())
    return text if len(text) <= MAX_COMMAND_LENGTH else text[: MAX_COMMAND_LENGTH - 3] + "..."


def _printable(value: Any, longest: int) -> str | None:
    if not isinstance(value, str) or not 0 < len(value) <= longest or not value.isprintable():
        return None
    return value


def origin_of(message: Any) -> Origin | None:
    """The `Origin` a `publisher` payload (decoded JSON) announces, or None when it holds none."""
    if not isinstance(message, dict):
        return None
    host = _printable(message.get("host"), MAX_HOST_LENGTH)
    command = _printable(message.get("command"), MAX_COMMAND_LENGTH)
    pid = message.get("pid")
    if host is None or command is None or not isinstance(pid, int) or isinstance(pid, bool) or not 0 < pid < 2**32:
        return None
    return Origin(host, pid, command)


@dataclass(frozen=True)
class Sender:
    """Who publishes: `source` (the Zenoh session id) and `stream` (random per start, 16 hex digits)."""

    source: str
    stream: str

    @classmethod
    def of(cls, zenoh_session: Any) -> Sender:
        """A new stream of `zenoh_session`'s publisher."""
        return cls(str(zenoh_session.zid()), secrets.token_hex(8))

    def fields(self) -> dict[str, str]:
        return {"source": self.source, "stream": self.stream}


def _sender_fields(sender: Sender | None) -> dict[str, str]:
    return sender.fields() if sender is not None else {}


def _vector(v: Sequence[float]) -> list[float | None]:
    """A vector's components to the sixth decimal, None where not finite; on Python floats
    (`_rows`), whose calls cost a tenth of numpy scalars' per component."""
    return [round(x, 6) if math.isfinite(x) else None for x in v]


def _rows(a: Any) -> list[list[float]]:
    """The rows of an (N, 3) array as lists of Python floats."""
    rows: list[list[float]] = np.asarray(a, dtype=float).tolist()
    return rows


@dataclass(frozen=True)
class MarkerRows:
    """A tracked frame's values as plain Python numbers, what a markers payload holds: `t` (s),
    `ids`, `position`, `velocity`, `filtered` (one [x, y, z] row per marker, m and m/s),
    `visible`, `views`. The Zenoh writer process unpacks a frame's record into these
    (`wiithrow.app.channels.records.unpack_marker_rows`) and formats them with no numpy array in
    between: woken once per poll, it runs each of its calls cold, and building the frame's arrays
    would be a quarter of its time from the poll's end to the put."""

    t: float
    ids: Sequence[int]
    position: Sequence[Sequence[float]]
    velocity: Sequence[Sequence[float]]
    filtered: Sequence[Sequence[float]]
    visible: Sequence[bool]
    views: Sequence[int]

    @classmethod
    def of(cls, frame: TrackedFrame) -> MarkerRows:
        return cls(
            t=float(frame.t),
            ids=frame.ids.tolist(),
            position=_rows(frame.position),
            velocity=_rows(frame.velocity),
            filtered=_rows(frame.filtered),
            visible=frame.visible.tolist(),
            views=frame.n_views.tolist(),
        )


def markers_message(
    rig: str,
    seq: int,
    frame: TrackedFrame | MarkerRows,
    frame_name: str,
    sent: float | None = None,
    *,
    sender: Sender | None = None,
) -> str:
    rows = frame if isinstance(frame, MarkerRows) else MarkerRows.of(frame)
    markers = [
        {
            "id": i,
            "position": _vector(p),
            "velocity": _vector(v),
            "filtered": _vector(f),
            "visible": vis,
            "views": n,
        }
        for i, p, v, f, vis, n in zip(rows.ids, rows.position, rows.velocity, rows.filtered, rows.visible, rows.views)
    ]
    return dumps_strict(
        {
            "schema": SCHEMA,
            "rig": rig,
            **_sender_fields(sender),
            "seq": seq,
            "t": rows.t,
            "sent": time.time() if sent is None else sent,
            "frame": frame_name,
            "markers": markers,
        }
    )


def dots_message(rig: str, seq: int, camera: int, frame: IRFrame, *, sender: Sender | None = None) -> str:
    dots = [
        [u, v] if math.isfinite(u) and math.isfinite(v) else None
        for u, v in np.asarray(frame.dots, dtype=float).tolist()
    ]
    return dumps_strict(
        {
            "schema": SCHEMA,
            "rig": rig,
            **_sender_fields(sender),
            "seq": seq,
            "camera": camera,
            "t": float(frame.t_device),
            "sent": time.time(),
            "dots": dots,
        }
    )


def throw_message(rig: str, seq: int, index: int, result: dict[str, Any], *, sender: Sender | None = None) -> str:
    return dumps_strict(
        {
            "schema": SCHEMA,
            "rig": rig,
            **_sender_fields(sender),
            "seq": seq,
            "sent": time.time(),
            "index": index,
            "result": result,
        }
    )


def publisher_message(rig: str, seq: int, origin: Origin, *, sender: Sender | None = None) -> str:
    return dumps_strict(
        {"schema": SCHEMA, "rig": rig, **_sender_fields(sender), "seq": seq, "sent": time.time(), **origin.fields()}
    )


def tracked_frame(message: dict[str, Any]) -> TrackedFrame:
    """A `markers` payload (decoded JSON) back as a TrackedFrame (null coordinates: NaN)."""
    if message.get("schema") != SCHEMA:
        raise ValueError(f"markers payload of schema {message.get('schema')!r}, this version reads {SCHEMA}")
    markers = message["markers"]

    def array(name: str) -> np.ndarray:
        if not markers:
            return np.zeros((0, 3))
        return np.array([[np.nan if x is None else x for x in m[name]] for m in markers], dtype=float)

    return TrackedFrame(
        t=float(message["t"]),
        ids=np.array([m["id"] for m in markers], dtype=np.int64),
        position=array("position"),
        velocity=array("velocity"),
        filtered=array("filtered"),
        visible=np.array([m["visible"] for m in markers], dtype=bool),
        n_views=np.array([m["views"] for m in markers], dtype=np.int64),
    )


def dots_of(message: Any, cameras: int) -> NDArray[np.float64] | None:
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
