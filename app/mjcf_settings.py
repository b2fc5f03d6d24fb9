"""`MjcfSettings`: a lab's own MuJoCo model (MJCF) as the MuJoCo world's physics, named by the
settings (`"mjcf": {...}`) and mapped onto the arm spec, so that the shipped MuJoCo drivers drive it
as they drive the project's own model (`wiithrow.app.worlds.mujoco.mjcf_world` builds it).

The planner keeps the spec's URDF: the MJCF is the lab's physics, which the planner does not know,
and its geometry and masses may differ from the URDF's by the model's own tolerances. Its world
frame is the arm's `base` (z up); joint 1 turns about its z axis through the origin, up to the
model's tolerances.

The mapping names the MJCF's own elements:

* `file`: the MJCF, a path inside the settings file's folder (relative or absolute; a path that
  leaves it is refused, a symbolic link inside it is followed: the rule of the spec's URDF,
  `wiithrow.robot.spec`), at most `MJCF_BYTES`;
* `arm_joints`, `arm_actuators`: one per arm joint, in the spec's order (joints and actuators
  contiguous in the model); the actuators are a motor, a velocity servo or a position servo each
  (`wiithrow.app.worlds.mujoco.arm_servo`);
* the hand: `finger_joints` and `finger_actuators` (one actuator per finger), the actuators'
  `finger_open_ctrl` and `finger_closed_ctrl` (what the hand's driver sends to open and to close),
  the joints' `finger_open_qpos` (fully open) and `finger_ball_qpos` (the pad on the ball: the
  hand's opening is measured between the two), and the two `pads`, the geoms that hold the ball;
* `ball`: the ball's body (a free joint, a sphere geom), `ball_seat`: the site where the ball
  sits in the hand (the spec's `ball` frame), `marker_led`: the hand's calibration LED's site;
* `floor`: the floor's geom; `table`: a mocap body with one box geom, the surface the lab's
  operator puts under a target (its top at the target's height).

The target's and the landing marker's LEDs are the operator's, added by the world. Every name
must be a string of at most `MAX_NAME` characters; a missing or malformed key is one line naming it.
"""

from __future__ import annotations

import math
import os
from collections.abc import Mapping
from dataclasses import dataclass, field, fields
from pathlib import Path
from typing import Any

from wiithrow.app.errors import AppError

#: How large an MJCF may be (bytes): a model with meshes keeps them in files of their own; the
#: worlds of the tests are 10-15 KB, a vendor's arm with its hand under 50 KB.
MJCF_BYTES = 4 * 2**20
#: The longest name of a model's element (MuJoCo has no limit; this is a typo's).
MAX_NAME = 200
#: The largest finger command or position (m or rad) a hand may state.
MAX_FINGER = 10.0

Names = tuple[str, ...]
Floats = tuple[float, ...]


@dataclass(frozen=True)
class MjcfSettings:
    """The mapping of a lab's MJCF onto the arm spec (module docstring). `base_dir`: the settings
    file's folder, which `file` is taken from (not written to files)."""

    file: str
    arm_joints: Names
    arm_actuators: Names
    finger_joints: Names
    finger_actuators: Names
    finger_open_ctrl: Floats
    finger_closed_ctrl: Floats
    finger_open_qpos: Floats
    finger_ball_qpos: Floats
    pads: Names
    ball: str
    ball_seat: str
    marker_led: str
    floor: str
    table: str
    base_dir: str = field(default="", compare=False)

    def path(self) -> Path:
        """The MJCF's path, checked (module docstring); AppError naming it otherwise."""
        folder = Path(os.path.normpath(os.path.abspath(self.base_dir or ".")))
        path = Path(os.path.normpath(folder / Path(self.file).expanduser()))
        if self.base_dir and not path.is_relative_to(folder):
            raise AppError(
                f"mjcf.file {self.file!r} is outside the settings file's folder ({folder}): put the MJCF in that "
                "folder, or a symbolic link to it"
            )
        if not path.is_file():
            raise AppError(f"mjcf.file: the lab's MJCF is missing: {path}")
        size = path.stat().st_size
        if size > MJCF_BYTES:
            raise AppError(
                f"mjcf.file {path}: {size / 1e6:.1f} MB, more than an MJCF may be ({MJCF_BYTES // 2**20} MiB: keep "
                "meshes in files of their own); nothing of it was read"
            )
        return path

    def to_dict(self) -> dict[str, Any]:
        """The mapping as a JSON object (`from_dict` reads it back); a relative `file` is written
        taken from `base_dir`."""
        out: dict[str, Any] = {f.name: _jsonable(getattr(self, f.name)) for f in fields(self) if f.name != "base_dir"}
        if self.base_dir and not Path(self.file).expanduser().is_absolute():
            out["file"] = str(Path(self.base_dir) / self.file)
        return out

    @classmethod
    def from_dict(cls, raw: object, *, base_dir: str = "", source: str = "settings") -> MjcfSettings:
        """The mapping in `raw` (a JSON object); AppError "SOURCE: mjcf.KEY ..." for the first bad key."""
        if not isinstance(raw, Mapping):
            raise AppError(
                f"{source}: mjcf must be an object (the lab's MJCF and its mapping), got {type(raw).__name__}"
            )
        known = [f.name for f in fields(cls) if f.name != "base_dir"]
        unknown = sorted(set(raw) - set(known))
        if unknown:
            raise AppError(f"{source}: unknown mjcf key(s) {unknown}; known: {sorted(known)}")
        missing = [k for k in known if k not in raw]
        if missing:
            raise AppError(f"{source}: mjcf lacks {', '.join(missing)}")
        values: dict[str, Any] = {}
        for f in fields(cls):
            if f.name == "base_dir":
                continue
            where = f"{source}: mjcf.{f.name}"
            value = raw[f.name]
            if f.type in ("str", str):
                values[f.name] = _name(value, where)
            elif f.type in ("Names", Names):
                if not isinstance(value, list) or not value:
                    raise AppError(f"{where} must be a list of names, got {value!r:.60}")
                values[f.name] = tuple(_name(v, f"{where}[{i}]") for i, v in enumerate(value))
            else:
                if not isinstance(value, list) or not value:
                    raise AppError(f"{where} must be a list of numbers, got {value!r:.60}")
                values[f.name] = tuple(_finger(v, f"{where}[{i}]") for i, v in enumerate(value))
        mapping = cls(**values, base_dir=base_dir)
        mapping.check_counts(source)
        return mapping

    def check_counts(self, source: str = "settings") -> None:
        """AppError unless the lists agree: an actuator per arm joint, one per finger, a command and
        positions per finger, two pads."""
        pairs = [
            ("arm_actuators", len(self.arm_joints), "one per arm joint"),
            ("finger_actuators", len(self.finger_joints), "one per finger joint"),
            ("finger_open_ctrl", len(self.finger_actuators), "one per finger actuator"),
            ("finger_closed_ctrl", len(self.finger_actuators), "one per finger actuator"),
            ("finger_open_qpos", len(self.finger_joints), "one per finger joint"),
            ("finger_ball_qpos", len(self.finger_joints), "one per finger joint"),
            ("pads", 2, "the two geoms that hold the ball"),
        ]
        for key, n, what in pairs:
            if len(getattr(self, key)) != n:
                raise AppError(f"{source}: mjcf.{key} needs {n} ({what}), got {len(getattr(self, key))}")
        for i, (opened, held) in enumerate(zip(self.finger_open_qpos, self.finger_ball_qpos)):
            if opened == held:
                raise AppError(
                    f"{source}: mjcf.finger_open_qpos[{i}] equals finger_ball_qpos[{i}]: the hand does not open"
                )


def _name(value: object, where: str) -> str:
    if not isinstance(value, str) or not value or len(value) > MAX_NAME:
        raise AppError(
            f"{where} must be the name of an element of the MJCF (1-{MAX_NAME} characters), got {value!r:.60}"
        )
    return value


def _finger(value: object, where: str) -> float:
    if isinstance(value, bool) or not isinstance(value, int | float) or not math.isfinite(value):
        raise AppError(f"{where} must be a number, got {value!r:.60}")
    if abs(value) > MAX_FINGER:
        raise AppError(f"{where} must be within +-{MAX_FINGER:g} (m or rad), got {value!r}")
    return float(value)


def _jsonable(v: object) -> object:
    return list(v) if isinstance(v, tuple) else v
