"""`ArmSpec`: everything the project needs to know of an arm, as data (JSON), so that an arm is
added by settings, not by editing the package.

A spec names the arm's URDF, its joint-1 convention, flange and tool frames, home pose, limits,
and how it throws (`ThrowingSpec`). The shipped arms are spec files in robot/specs/ (`pa10.json`,
`panda.json`, `ur5e.json`, `ur5.json`), read by the same `ArmSpec.from_dict` that reads the
`arm_spec` object of a settings file. Units: m, rad, rad/s, rad/s^2, rad/s^3, s.

URDF references (`ArmSpec.urdf`), each confined to its folder:
- `"wiithrow:<file>"`: a URDF shipped in robot/urdf/ (the PA-10's and the UR5e's, written by the
  project's generator scripts there); the path must resolve inside that folder;
- `"example-robot-data:<path>"`: a file under example-robot-data's `robots` folder (the Panda),
  likewise inside it;
- anything else: a file path. A spec read from a settings file (`base_dir`, the file's folder)
  names a file inside that folder, relative or absolute: a path that leaves it (`../x.urdf`,
  `/etc/passwd`) is refused. The allow rule for a URDF kept elsewhere: a symbolic link inside the
  folder, which the lab made, is followed. A spec built in code (no `base_dir`) names any path.

Every list of per-joint figures has one value per arm joint (the first `len(home)` joints of the
URDF; later ones, grippers, are locked). A figure left out (null) comes from the URDF (position,
velocity) or from the 0.225 s rule (acceleration, jerk; `wiithrow.robot.arms`). Every figure, the
spec's and the URDF's, must lie within the physical bounds below (`JOINT_BOUNDS`, docs/robot.md
"Limits"). Bad input is a `RobotError` naming the key, in one line.
"""

from __future__ import annotations

import json
import math
import os
from collections.abc import Mapping
from dataclasses import dataclass, field, fields
from pathlib import Path
from typing import Any

from wiithrow.robot.errors import RobotError

SPEC_DIR = Path(__file__).resolve().parent / "specs"
URDF_DIR = Path(__file__).resolve().parent / "urdf"
#: How large an arm spec file may be (bytes): the largest shipped, the Panda's, is 2 KB.
MAX_SPEC_BYTES = 2**20

#: The physical bounds of a joint's figures, inclusive (docs/robot.md, "Limits"): a figure beyond
#: them is a typo or a unit slip (degrees for radians, 1e9 for 1), never an arm. Position: two
#: turns each way (4 pi rad); the widest revolute joints of industrial arms turn one way +-2 pi
#: (the UR5e's), cables allow no more. Velocity: 50 rad/s; the shipped arms' fastest joints turn
#: at 6.3 rad/s (the PA-10's wrists, 2 pi), industrial arms' fastest wrists at about 10 rad/s.
#: Acceleration: 1,000 rad/s^2; the shipped arms' largest is 42 (the PA-10's wrists), and the
#: 0.225 s rule at 50 rad/s gives 333. Jerk: 100,000 rad/s^3; the Panda's published largest is
#: 10,000, the rule at 50 rad/s gives 4,444.
MAX_JOINT_POSITION_RAD = 4 * math.pi
MAX_JOINT_VELOCITY = 50.0  # rad/s
MAX_JOINT_ACCELERATION = 1_000.0  # rad/s^2
MAX_JOINT_JERK = 100_000.0  # rad/s^3
#: (low, high, unit) of each per-joint figure of a spec (the velocity, acceleration and jerk
#: must also be above 0).
JOINT_BOUNDS: Mapping[str, tuple[float, float, str]] = {
    "home": (-MAX_JOINT_POSITION_RAD, MAX_JOINT_POSITION_RAD, "rad"),
    "lower": (-MAX_JOINT_POSITION_RAD, MAX_JOINT_POSITION_RAD, "rad"),
    "upper": (-MAX_JOINT_POSITION_RAD, MAX_JOINT_POSITION_RAD, "rad"),
    "velocity": (0.0, MAX_JOINT_VELOCITY, "rad/s"),
    "acceleration": (0.0, MAX_JOINT_ACCELERATION, "rad/s^2"),
    "jerk": (0.0, MAX_JOINT_JERK, "rad/s^3"),
}
#: How far from the joint-1 axis and the base's floor a training area may reach (m): a ball an
#: arm throws lands within a few metres (the PA-10's reach on the floor is 2.2 m).
MAX_AREA_M = 20.0
#: The longest acceleration phase of a throw (s): the shipped arms' are 0.32-0.48 s.
MAX_ACCELERATION_TIME_S = 5.0

Floats = tuple[float, ...]


@dataclass(frozen=True)
class ThrowingSpec:
    """How an arm throws (see `wiithrow.throwing.representation`).

    `joints`: the pitch joints the throw moves (all about axes parallel to link1's y axis, so the
    ball stays in a plane y = const of link1), in the order of the throw parameters;
    `held`: (joint, angle rad) of every other joint except joint 1, held during the throw;
    `plane_joint`: "" or one held joint whose angle is solved (starting from the stated one) so
    that the ball lies in link1's plane y = 0, the throw plane (the UR's wrist 2: its wrist is
    0.133 m off the shoulder's plane);
    `nominal_release` (rad): the release pose the simulated operator prefers (one per joint);
    `directions` (+1 or -1 per joint, default +1): the sign of each joint's velocity in a throw
    (its wind-up is on the other side of the release, its follow-through on this side; the
    Panda's elbow and wrist fold, -1);
    `area_x`, `area_z` (m): the training area in the throw plane (distance from the joint-1 axis,
    height), reachable at the velocity margin (tested: the operator throws at every corner within
    90 % of it); `acceleration_time` (s): the throw's acceleration phase T (a multiple of 0.04 s),
    long enough that its peaks 15/8 |dq|/T and 5.77 |dq|/T^2 stay within the limits.
    """

    joints: tuple[str, ...]
    held: tuple[tuple[str, float], ...]
    nominal_release: Floats
    area_x: tuple[float, float]
    area_z: tuple[float, float]
    acceleration_time: float = 0.32
    plane_joint: str = ""
    directions: tuple[int, ...] = ()

    def __post_init__(self) -> None:
        object.__setattr__(self, "joints", tuple(str(j) for j in self.joints))
        object.__setattr__(self, "held", tuple((str(n), float(v)) for n, v in self.held))
        object.__setattr__(self, "nominal_release", _floats(self.nominal_release, "throwing.nominal_release"))
        _within(
            self.nominal_release, "throwing.nominal_release", -MAX_JOINT_POSITION_RAD, MAX_JOINT_POSITION_RAD, "rad"
        )
        _within([v for _, v in self.held], "throwing.held", -MAX_JOINT_POSITION_RAD, MAX_JOINT_POSITION_RAD, "rad")
        for key in ("area_x", "area_z"):
            lo, hi = _floats(getattr(self, key), f"throwing.{key}", 2)
            _within((lo, hi), f"throwing.{key}", -MAX_AREA_M, MAX_AREA_M, "m")
            if not lo < hi:
                raise RobotError(f"arm spec: throwing.{key} must be [low, high] with low < high, got {[lo, hi]}")
            object.__setattr__(self, key, (lo, hi))
        if len(self.nominal_release) != len(self.joints):
            raise RobotError(
                f"arm spec: throwing.nominal_release needs one angle per throwing joint ({len(self.joints)}), "
                f"got {len(self.nominal_release)}"
            )
        dirs = tuple(self.directions) or (1,) * len(self.joints)
        if len(dirs) != len(self.joints) or any(d not in (1, -1) or isinstance(d, bool) for d in dirs):
            raise RobotError(f"arm spec: throwing.directions needs +1 or -1 per throwing joint, got {list(dirs)}")
        object.__setattr__(self, "directions", tuple(int(d) for d in dirs))
        if not (math.isfinite(self.acceleration_time) and 0 < self.acceleration_time <= MAX_ACCELERATION_TIME_S):
            raise RobotError(
                f"arm spec: throwing.acceleration_time must be above 0 and at most {MAX_ACCELERATION_TIME_S:g} s, "
                f"got {self.acceleration_time:g}"
            )
        if self.plane_joint and self.plane_joint not in {n for n, _ in self.held}:
            raise RobotError(f"arm spec: throwing.plane_joint {self.plane_joint!r} must be one of the held joints")


@dataclass(frozen=True)
class ArmSpec:
    """One arm (module docstring). `name`: how settings and libraries call it; `urdf`: where its
    URDF is; `joint1`: the joint that turns the throw plane about the vertical axis (the URDF's
    first joint, vertical through the base origin: checked at load); `flange`: the URDF frame that
    is the tool flange (z out of the hand); `marker_offset`, `ball_offset` (m): the tool frames
    `marker` (the calibration LED) and `ball` beyond the flange along its z; `home` (rad, one per
    arm joint); `lower`, `upper` (rad), `velocity` (rad/s), `acceleration` (rad/s^2), `jerk`
    (rad/s^3): per joint, or None (module docstring); `throwing`: how it throws, or None (it does
    not); `description` and `sources` (where every figure comes from), free text."""

    name: str
    urdf: str
    joint1: str
    flange: str
    home: Floats
    marker_offset: float = 0.10
    ball_offset: float = 0.15
    lower: Floats | None = None
    upper: Floats | None = None
    velocity: Floats | None = None
    acceleration: Floats | None = None
    jerk: Floats | None = None
    throwing: ThrowingSpec | None = None
    description: str = ""
    sources: str = ""
    #: the folder a relative `urdf` path is taken from (the settings file's); not written to files
    base_dir: str = field(default="", compare=False)

    def __post_init__(self) -> None:
        for key in ("name", "urdf", "joint1", "flange"):
            v = getattr(self, key)
            if not isinstance(v, str) or not v:
                raise RobotError(f"arm spec: {key} must be a non-empty string, got {v!r:.60}")
        object.__setattr__(self, "home", _floats(self.home, "home"))
        n = len(self.home)
        if n < 1:
            raise RobotError("arm spec: home needs one angle per arm joint")
        for key in ("lower", "upper", "velocity", "acceleration", "jerk"):
            v = getattr(self, key)
            if v is not None:
                object.__setattr__(self, key, _floats(v, key, n))
        for key in ("velocity", "acceleration", "jerk"):
            v = getattr(self, key)
            if v is not None and min(v) <= 0:
                raise RobotError(f"arm spec: every {key} limit must be > 0, got {list(v)}")
        check_joint_figures({key: getattr(self, key) for key in JOINT_BOUNDS})
        if self.lower is not None and self.upper is not None:
            for i, (lo, hi) in enumerate(zip(self.lower, self.upper)):
                if not lo < hi:
                    raise RobotError(f"arm spec: lower[{i}] must be below upper[{i}], got {lo:g} and {hi:g}")
        _check_urdf_reference(self.urdf, self.base_dir)
        for key in ("marker_offset", "ball_offset"):
            v = getattr(self, key)
            if isinstance(v, bool) or not isinstance(v, int | float) or not 0.0 <= v <= 1.0:
                raise RobotError(f"arm spec: {key} must be a number from 0 to 1 m beyond the flange, got {v!r:.60}")

    # ----- the URDF ---------------------------------------------------------------------------------

    def urdf_file(self) -> Path:
        """The URDF's path (module docstring); RobotError if it is not there."""
        from wiithrow.robot.arms import example_robot_data_dir  # the package's location, found lazily

        if self.urdf.startswith("wiithrow:"):
            path = _inside(URDF_DIR, self.urdf.removeprefix("wiithrow:"), self.urdf, "the package's URDF folder")
        elif self.urdf.startswith("example-robot-data:"):
            robots = example_robot_data_dir()
            path = _inside(
                robots, self.urdf.removeprefix("example-robot-data:"), self.urdf, "example-robot-data's robots folder"
            )
        else:
            path = Path(self.urdf).expanduser()
            if not path.is_absolute() and self.base_dir:
                path = Path(self.base_dir) / path
        if not path.is_file():
            raise RobotError(f"the URDF of arm '{self.name}' is missing: {path}")
        return path

    # ----- files ------------------------------------------------------------------------------------

    def to_dict(self) -> dict[str, Any]:
        """The spec as a JSON object (`from_dict` reads it back); a relative URDF path is written
        taken from `base_dir`, so the object means the same wherever it is written."""
        out: dict[str, Any] = {}
        for f in fields(self):
            if f.name == "base_dir":
                continue
            v = getattr(self, f.name)
            if isinstance(v, ThrowingSpec):
                v = {g.name: _jsonable(getattr(v, g.name)) for g in fields(v)}
            out[f.name] = _jsonable(v)
        if self.base_dir and ":" not in self.urdf.split("/")[0] and not Path(self.urdf).expanduser().is_absolute():
            out["urdf"] = str(Path(self.base_dir) / self.urdf)
        return out

    @classmethod
    def from_dict(cls, d: object, *, base_dir: str = "", source: str = "arm spec") -> ArmSpec:
        """The spec in `d` (a JSON object); RobotError "SOURCE: ..." naming the bad key."""
        try:
            if not isinstance(d, Mapping):
                raise RobotError(f"an arm spec is a JSON object, got {type(d).__name__}")
            _known(d, cls, "")
            values = dict(d)
            t = values.get("throwing")
            if t is not None:
                if not isinstance(t, Mapping):
                    raise RobotError(f"throwing must be an object, got {type(t).__name__}")
                _known(t, ThrowingSpec, "throwing.")
                tv = dict(t)
                held = tv.get("held", ())
                if not isinstance(held, list | tuple) or not all(
                    isinstance(h, list | tuple) and len(h) == 2 and isinstance(h[0], str) for h in held
                ):
                    raise RobotError(f"throwing.held must be a list of [joint, angle] pairs, got {held!r:.60}")
                tv["held"] = tuple((h[0], _float(h[1], "throwing.held")) for h in held)
                tv["acceleration_time"] = _float(tv.get("acceleration_time", 0.32), "throwing.acceleration_time")
                try:
                    values["throwing"] = ThrowingSpec(**tv)
                except TypeError as exc:
                    raise RobotError(f"throwing: {exc}") from None
            return cls(**values, base_dir=base_dir)
        except RobotError as exc:
            raise RobotError(f"{source}: {str(exc).removeprefix('arm spec: ')}") from None
        except TypeError as exc:  # a required key is missing
            raise RobotError(f"{source}: {exc}") from None

    @classmethod
    def load(cls, path: str | Path) -> ArmSpec:
        """The spec in the JSON file `path` (a relative `urdf` is taken from its folder)."""
        p = Path(path)
        try:
            with p.open("rb") as handle:
                raw = handle.read(MAX_SPEC_BYTES + 1)
            if len(raw) > MAX_SPEC_BYTES:
                raise RobotError(
                    f"{p}: more than an arm spec may be ({MAX_SPEC_BYTES // 2**20} MiB: the Panda's is 2 KB)"
                )
            data = json.loads(raw.decode("utf-8"))
        except (OSError, UnicodeDecodeError, RecursionError, json.JSONDecodeError) as exc:
            raise RobotError(f"{p}: not a readable arm spec ({exc})") from None
        return cls.from_dict(data, base_dir=str(p.parent), source=str(p))


def shipped_specs() -> dict[str, ArmSpec]:
    """The arms the package ships (robot/specs/*.json), by name; the PA-10 first."""
    specs = [ArmSpec.load(p) for p in sorted(SPEC_DIR.glob("*.json"))]
    specs.sort(key=lambda s: (s.name != "pa10", s.name))
    return {s.name: s for s in specs}


def _known(d: Mapping[str, Any], cls: type, prefix: str) -> None:
    """RobotError naming the keys of `d` that `cls` does not have, or the ones it needs and `d` lacks."""
    from dataclasses import MISSING

    names = {f.name for f in fields(cls)} - {"base_dir"}
    unknown = sorted(set(d) - names)
    if unknown:
        raise RobotError(f"unknown key(s) {[prefix + k for k in unknown]}; known: {sorted(names)}")
    missing = [prefix + f.name for f in fields(cls) if f.default is MISSING and f.name not in d]
    if missing:
        raise RobotError(f"missing key(s) {missing}")


def check_joint_figures(figures: Mapping[str, Any], where: str = "arm spec") -> None:
    """RobotError "WHERE: KEY[i] must be a number from LOW to HIGH UNIT, got V" for the first
    per-joint figure (`JOINT_BOUNDS`' keys; None: not given) outside its physical bound."""
    for key, values in figures.items():
        if values is not None:
            low, high, unit = JOINT_BOUNDS[key]
            _within(values, key, low, high, unit, where)


def _within(values: Any, key: str, low: float, high: float, unit: str, where: str = "arm spec") -> None:
    for i, v in enumerate(values):
        if not low <= float(v) <= high:  # NaN fails too
            raise RobotError(f"{where}: {key}[{i}] must be a number from {low:g} to {high:g} {unit}, got {float(v):g}")


def _check_urdf_reference(urdf: str, base_dir: str) -> None:
    """RobotError for a URDF reference that leaves its folder (module docstring), said before
    anything is read: a package path that climbs out of the package's folder, a plain path of a
    spec from a settings file (`base_dir`) outside that file's folder."""
    if urdf.startswith("wiithrow:"):
        _inside(URDF_DIR, urdf.removeprefix("wiithrow:"), urdf, "the package's URDF folder")
    elif urdf.startswith("example-robot-data:"):
        relative = Path(os.path.normpath(urdf.removeprefix("example-robot-data:")))
        if relative.is_absolute() or relative.parts[:1] == ("..",):
            raise RobotError(f"arm spec: urdf {urdf!r} leaves example-robot-data's robots folder: name a file in it")
    elif base_dir:
        folder = Path(os.path.normpath(os.path.abspath(base_dir)))
        path = Path(os.path.normpath(folder / Path(urdf).expanduser()))  # lexical: a link inside is followed later
        if not path.is_relative_to(folder):
            raise RobotError(
                f"arm spec: urdf {urdf!r} is outside the settings file's folder ({folder}): put the URDF in that "
                "folder, or a symbolic link to it"
            )


def _inside(folder: Path, relative: str, urdf: str, what: str) -> Path:
    """`folder / relative`, resolved; RobotError when it lies outside `folder`."""
    root = folder.resolve()
    path = (root / relative).resolve()
    if not path.is_relative_to(root):
        raise RobotError(f"arm spec: urdf {urdf!r} leaves {what} ({root}): name a file in it")
    return path


def _float(v: object, key: str) -> float:
    if isinstance(v, bool) or not isinstance(v, int | float) or not math.isfinite(v):
        raise RobotError(f"{key} must be a finite number, got {v!r:.60}")
    return float(v)


def _floats(v: object, key: str, n: int | None = None) -> Floats:
    if not isinstance(v, list | tuple):
        raise RobotError(f"{key} must be a list of numbers, got {v!r:.60}")
    out = tuple(_float(x, key) for x in v)
    if n is not None and len(out) != n:
        raise RobotError(f"{key} must have {n} values (one per joint), got {len(out)}")
    return out


def _jsonable(v: object) -> object:
    if isinstance(v, tuple):
        return [_jsonable(x) for x in v]
    return v
