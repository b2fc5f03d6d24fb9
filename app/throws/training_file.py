"""A training run's progress file, `<library>.training.json`: the run saved after every step so
that a Stop, a crash or a restart resumes where it was; and what it may say.

The file sits beside the library the session was told to write (`--train-to`, or the session's
default in the user's cache: `progress_path`), and names no path: where the library and the file
go is the command's to say, never the file's (a file anyone can edit must not choose what the
session writes or replaces). Reading it checks, in one line naming the file and the throw (a
`TrainingFileError`, and the file is left as it was):

* its size first (`files.TRAINING_RUN_SIZE`, before it is read), its kind and schema, and no key
  beyond the format's (a misspelt or foreign key is not silently dropped);
* every number: the area within `MAX_AREA_M` of joint 1 (the spec's bound), each target inside
  the area (the targets are made from it), the release parameters' angles within two turns and
  speeds within the spec's joint velocity bound, the world's landing and the measured one within
  `MAX_AREA_M`, `release_off_m` from 0 to `MAX_RELEASE_OFF_M`, the throw's joint-1 angle
  `q1_rad` within two turns and its measured across offset `measured_across_m` within `MAX_AREA_M`
  (both optional: a file from before they were kept has neither); strings (notes, the arm) bounded;
* a measured throw's `measured_by` (schema 2): a known source, a calibration fingerprint, a
  frame and a time. Whether the landing is plausible for its throw is checked before a fit
  (`landing_checks`), where the arm and the area are known.

Schema 1 (before the file stopped naming paths) is still read: its `library` field must name the
library the file sits beside (the same file, or a relative path of the same name) and is
otherwise refused; its measured throws have no `measured_by` (the library's meta counts them as
unrecorded); the next save writes schema 2.
"""

from __future__ import annotations

import json
import os
import re
from datetime import datetime
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from wiithrow.app.throws.training_run import MAX_THROWS, SOURCES, STATES, Measurement, TrainingRun, TrainingThrow
from wiithrow.robot.spec import MAX_AREA_M, MAX_JOINT_POSITION_RAD, MAX_JOINT_VELOCITY
from wiithrow.throwing import Area, ThrowingError, ThrowParameters
from wiithrow.vision.errors import FileFormatError
from wiithrow.vision.files import TRAINING_RUN_SIZE, atomic_write_text, loads_json, read_text

KIND = "wiithrow.training_run"
SCHEMA = 2
#: The schemas read: 1 named the library (checked, then dropped), 2 names no path.
READ_SCHEMAS = (1, 2)

#: How far (m) from its planned release the hand may have been told to open, at most: farther is
#: no throw (the arm's reach is 1-1.5 m), a number no executed throw gives.
MAX_RELEASE_OFF_M = 10.0
#: The longest note or arm name, and the most notes, a file may hold (the session's are one line
#: of under 300 characters, a few of them).
MAX_TEXT_CHARS = 1000
MAX_NOTES = 20
#: How far (m) a target may lie outside its run's area (rounding of the area's corners).
TARGET_SLACK_M = 1e-6

_RUN_KEYS = frozenset({"kind", "schema", "arm", "area", "notes", "throws"})
_THROW_KEYS = frozenset(
    {
        "target",
        "state",
        "params",
        "landing_base",
        "measured",
        "measured_by",
        "note",
        "release_off_m",
        "q1_rad",
        "measured_across_m",
    }
)
_FINGERPRINT = re.compile(r"[0-9a-f]{16}")


class TrainingFileError(FileFormatError):
    """A training progress file that cannot be resumed (named, with why)."""


def progress_path(library: str | os.PathLike[str]) -> Path:
    """Where the run that writes `library` keeps its progress: `<library stem>.training.json` beside it."""
    path = Path(library)
    return path.with_name(path.stem + ".training.json")


def save_run(path: str | os.PathLike[str], run: TrainingRun) -> Path:
    """Write `run` to `path` atomically (a crash leaves the old file or the new, never half of one)."""
    document = {"kind": KIND, "schema": SCHEMA, **run.to_dict()}
    return atomic_write_text(path, json.dumps(document, indent=1, allow_nan=False) + "\n")


def load_run(path: str | os.PathLike[str], library: str | os.PathLike[str]) -> TrainingRun | None:
    """The run saved at `path`, the progress of `library` (what a schema-1 file's `library` must
    name), or None when there is none; TrainingFileError for a file that cannot be resumed (module
    docstring)."""
    path = Path(path)
    if not path.exists():
        return None
    try:
        document = loads_json(read_text(path, TRAINING_RUN_SIZE), str(path))
    except FileFormatError as exc:
        raise TrainingFileError(f"{exc}; remove it to start the training again") from None
    return run_from_dict(document, str(path), Path(library))


def run_from_dict(d: Any, where: str, library: Path) -> TrainingRun:
    """The run in the progress file's document `d` (module docstring: every key and number
    checked); TrainingFileError "WHERE: ..." otherwise."""
    if not isinstance(d, dict) or d.get("kind") != KIND:
        raise TrainingFileError(f"{where}: not a training run (kind {KIND!r} expected)")
    schema = d.get("schema")
    if schema not in READ_SCHEMAS:
        raise TrainingFileError(f"{where}: training run schema {schema!r} is not supported (reads {READ_SCHEMAS})")
    if schema == 1:
        _check_named_library(d.get("library"), where, library)
        d = {k: v for k, v in d.items() if k != "library"}
    try:
        _known(d, _RUN_KEYS, "")
        arm = _text(d["arm"], "arm")
        area = Area(_range(d["area"]["x_m"], "area.x_m"), _range(d["area"]["z_m"], "area.z_m"))
        raw = d["throws"]
        if not isinstance(raw, list) or not 1 <= len(raw) <= MAX_THROWS:
            raise ValueError(f"throws must be a list of 1 to {MAX_THROWS}")
        throws = []
        for i, t in enumerate(raw):
            try:
                throws.append(_throw(t, area, schema))
            except (KeyError, TypeError, ValueError, ThrowingError) as exc:
                raise ValueError(f"throw {i + 1}: {_reason(exc)}") from None
        notes = d.get("notes", [])
        if not isinstance(notes, list) or len(notes) > MAX_NOTES:
            raise ValueError(f"notes must be a list of at most {MAX_NOTES}")
        return TrainingRun(arm, area, tuple(throws), tuple(_text(n, "a note") for n in notes))
    except (KeyError, TypeError, ValueError) as exc:
        raise TrainingFileError(f"{where}: a broken training run ({_reason(exc)}); remove it to start again") from None


def _check_named_library(named: Any, where: str, library: Path) -> None:
    """A schema-1 file's `library` must be the library the file is the progress of."""
    if isinstance(named, str) and named:
        same = Path(os.path.abspath(named)) == Path(os.path.abspath(library))
        same_name = not Path(named).is_absolute() and Path(named).name == library.name
        if same or same_name:
            return
    raise TrainingFileError(
        f"{where}: names the library {named!r:.200}, not {library} beside it: a progress file does not choose where "
        "the library goes; move it away to train"
    )


def _throw(d: Any, area: Area, schema: int) -> TrainingThrow:
    if not isinstance(d, dict):
        raise ValueError(f"a training throw is a JSON object, got {type(d).__name__}")
    _known(d, _THROW_KEYS - ({"measured_by"} if schema == 1 else set()), "")
    state = d.get("state")
    if state not in STATES:
        raise ValueError(f"unknown state {state!r:.40} (one of {', '.join(STATES)})")
    target = _within(d["target"], 2, "target", MAX_AREA_M)
    (x0, x1), (z0, z1) = area.x, area.z
    if not (
        x0 - TARGET_SLACK_M <= target[0] <= x1 + TARGET_SLACK_M
        and z0 - TARGET_SLACK_M <= target[1] <= z1 + TARGET_SLACK_M
    ):
        raise ValueError(f"target {target.tolist()} is outside the run's area {area}")
    params = _params(d["params"]) if d.get("params") is not None else None
    measured_by = _measurement(d["measured_by"]) if d.get("measured_by") is not None else None
    release_off = d.get("release_off_m")
    if release_off is not None:
        release_off = float(_within([release_off], 1, "release_off_m", MAX_RELEASE_OFF_M)[0])
        if release_off < 0:
            raise ValueError(f"release_off_m must be a distance from 0 to {MAX_RELEASE_OFF_M:g} m, got {release_off:g}")
    q1 = d.get("q1_rad")
    q1 = None if q1 is None else float(_within([q1], 1, "q1_rad", MAX_JOINT_POSITION_RAD)[0])
    across = d.get("measured_across_m")
    across = None if across is None else float(_within([across], 1, "measured_across_m", MAX_AREA_M)[0])
    throw = TrainingThrow(
        target,
        state,
        params,
        None if d.get("landing_base") is None else _within(d["landing_base"], 3, "landing_base", MAX_AREA_M),
        None if d.get("measured") is None else _within(d["measured"], 2, "measured", MAX_AREA_M),
        _text(d.get("note", ""), "note"),
        release_off,
        measured_by,
        q1,
        across,
    )
    if state in ("thrown", "measured") and params is None:
        raise ValueError(f"a {state} throw needs its params")
    if state == "measured" and throw.measured is None:
        raise ValueError("a measured throw needs its measured landing")
    if state == "measured" and schema >= 2 and measured_by is None:
        raise ValueError("a measured throw needs measured_by: what measured its landing")
    if state != "measured" and (throw.measured is not None or measured_by is not None or across is not None):
        raise ValueError(f"a {state} throw has no measured landing")
    return throw


def _params(d: Any) -> ThrowParameters:
    """Release parameters within two turns (rad) and the spec's joint speed bound (rad/s)."""
    if not isinstance(d, dict) or set(d) != {"q_release", "dq_release"}:
        raise ValueError("params must be {q_release, dq_release}")
    q = _within(d["q_release"], None, "params.q_release", MAX_JOINT_POSITION_RAD)
    dq = _within(d["dq_release"], None, "params.dq_release", MAX_JOINT_VELOCITY)
    return ThrowParameters(q, dq)


def _measurement(d: Any) -> Measurement:
    if not isinstance(d, dict):
        raise ValueError("measured_by must be an object")
    _known(d, frozenset({"source", "calibration", "frame", "time"}), "measured_by.")
    source = d["source"]
    if source not in SOURCES:
        raise ValueError(f"measured_by.source must be one of {list(SOURCES)}, got {source!r:.40}")
    fingerprint = d["calibration"]
    if not isinstance(fingerprint, str) or not _FINGERPRINT.fullmatch(fingerprint):
        raise ValueError(
            f"measured_by.calibration must be a calibration's fingerprint (16 hex digits), got {fingerprint!r:.40}"
        )
    frame = _text(d["frame"], "measured_by.frame")
    time = _text(d["time"], "measured_by.time")
    try:
        datetime.fromisoformat(time)
    except ValueError:
        raise ValueError(f"measured_by.time must be an ISO 8601 time, got {time!r:.40}") from None
    return Measurement(source, fingerprint, frame, time)


def _within(values: Any, n: int | None, what: str, bound: float) -> NDArray[np.float64]:
    """`values` as n (None: any number of) finite numbers of magnitude at most `bound`."""
    if not isinstance(values, list) or not all(isinstance(v, int | float) and not isinstance(v, bool) for v in values):
        raise ValueError(f"{what} must be a list of numbers, got {values!r:.60}")
    a = np.array(values, dtype=float)
    if (n is not None and a.shape != (n,)) or not np.isfinite(a).all():
        count = "" if n is None else f"{n} "
        raise ValueError(f"{what} must be {count}finite numbers, got {values!r:.60}")
    if a.size and np.abs(a).max() > bound:
        raise ValueError(f"{what} must lie within +-{bound:g}, got {values!r:.60}")
    return a


def _range(values: Any, what: str) -> tuple[float, float]:
    a = _within(values, 2, what, MAX_AREA_M)
    if not a[0] < a[1]:
        raise ValueError(f"{what} must be (low, high) with low < high, got {values!r:.60}")
    return float(a[0]), float(a[1])


def _text(value: Any, what: str) -> str:
    if not isinstance(value, str) or len(value) > MAX_TEXT_CHARS:
        raise ValueError(f"{what} must be a text of at most {MAX_TEXT_CHARS} characters")
    return value


def _known(d: dict[str, Any], keys: frozenset[str], prefix: str) -> None:
    unknown = sorted(set(d) - keys)
    if unknown:
        raise ValueError(f"unknown key(s) {[prefix + k for k in unknown]!r:.200}")


def _reason(exc: BaseException) -> str:
    """An exception's message as one clause (a KeyError's is the missing key)."""
    if isinstance(exc, KeyError):
        return f"{exc.args[0]!r} is missing"
    return str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
