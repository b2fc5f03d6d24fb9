"""The catalogue of arms and `load_arm`: URDF -> Pinocchio model -> `ArmModel` with named frames.

Known arms: "pa10" (the project's own URDF, robot/urdf/pa10.urdf), "panda" and "ur5" (URDFs of the
example-robot-data package, found under its `cmeel.prefix/share/example-robot-data/robots`).

Every arm gets the same named frames (added as Pinocchio OP_FRAMEs where the URDF lacks them):
- `base`: the root, z up; it is Pinocchio's world frame, so every position is in `base`.
  A URDF frame already called `base` with another meaning (the UR5's ROS-Industrial `base`,
  turned by pi about z) is renamed to `urdf:base`.
- `link1`: attached to joint 1 and equal to `base` at q1 = 0, so it is `base` turned by q1 about
  z (joint 1 of every known arm is vertical through the base origin). Its plane y = 0 is the
  plane the arm moves in when the other vertical joints are at zero; its (x, z) are distance and
  height.
- `flange`: the tool flange, z pointing out of the hand (PA-10: DH frame 7; Panda: panda_link8;
  UR5: tool0).
- `marker` (the IR LED held by the hand for calibration) and `ball` (where the ball sits before
  release): the flange translated along its z axis by `marker_offset` (default 0.10 m) and
  `ball_offset` (default 0.15 m), same orientation as the flange.

Grippers are locked (Panda fingers closed), so q holds the arm's joints only.

Acceleration and jerk limits: no public PA-10 figures exist, so they are settings. The defaults
give every joint the time to reach its velocity limit from rest of
    t = v/a + a/j = 0.15 s + 0.075 s = 0.225 s   (a = v / 0.15 s, j = a / 0.075 s),
which lets the elbow E1 (2 rad/s) and the wrist W1 (2 pi rad/s) reach full speed within the
0.2-0.3 s of a throw's acceleration phase. For the PA-10 these are rounded to
a = (7, 7, 14, 14, 42, 42, 42) rad/s^2 and j = (90, 90, 180, 180, 540, 540, 540) rad/s^3.
The Panda uses Franka's published limits; the UR5 the same 0.225 s rule.
"""

from __future__ import annotations

import importlib.metadata
import sysconfig
from dataclasses import dataclass
from pathlib import Path
from types import MappingProxyType

import numpy as np
import pinocchio as pin
from numpy.typing import ArrayLike

from wiithrow.robot.errors import RobotError
from wiithrow.robot.limits import JointLimits
from wiithrow.robot.model import ArmModel

#: Default offsets (m) of the named tool frames beyond the flange, along the flange z axis.
DEFAULT_FRAME_OFFSETS = MappingProxyType({"marker": 0.10, "ball": 0.15})

#: The time-to-full-speed rule of the default acceleration and jerk limits (see the module docstring).
ACCEL_TIME = 0.15  # s: a = v / ACCEL_TIME
JERK_TIME = 0.075  # s: j = a / JERK_TIME

URDF_DIR = Path(__file__).resolve().parent / "urdf"


@dataclass(frozen=True)
class ArmSpec:
    """How to build one known arm."""

    urdf: str  # "pa10.urdf" (in robot/urdf) or "erd:<path under example-robot-data/robots>"
    flange_source: str  # URDF frame that is the flange ("flange" itself for the PA-10)
    home: tuple[float, ...]
    acceleration: tuple[float, ...] | None = None  # None: the 0.225 s rule
    jerk: tuple[float, ...] | None = None
    description: str = ""


ARMS: dict[str, ArmSpec] = {
    "pa10": ArmSpec(
        urdf="pa10.urdf",
        flange_source="flange",
        # elbow bent, forearm about horizontal, flange at (0.65, 0, 0.59) m, hand pointing forward-down
        home=(0.0, 0.3, 0.0, 1.5, 0.0, 0.6, 0.0),
        acceleration=(7.0, 7.0, 14.0, 14.0, 42.0, 42.0, 42.0),
        jerk=(90.0, 90.0, 180.0, 180.0, 540.0, 540.0, 540.0),
        description="Mitsubishi PA-10 (PA10-7C), 7 joints S1 S2 S3 E1 E2 W1 W2",
    ),
    "panda": ArmSpec(
        urdf="erd:panda_description/urdf/panda.urdf",
        flange_source="panda_link8",
        home=(0.0, -np.pi / 4, 0.0, -3 * np.pi / 4, 0.0, np.pi / 2, np.pi / 4),
        acceleration=(15.0, 7.5, 10.0, 12.5, 15.0, 20.0, 20.0),
        jerk=(7500.0, 3750.0, 5000.0, 6250.0, 7500.0, 10000.0, 10000.0),
        description="Franka Emika Panda (example-robot-data), 7 joints, fingers locked closed",
    ),
    "ur5": ArmSpec(
        urdf="erd:ur_description/urdf/ur5_robot.urdf",
        flange_source="tool0",
        home=(0.0, -np.pi / 2, np.pi / 2, -np.pi / 2, -np.pi / 2, 0.0),
        description="Universal Robots UR5 (example-robot-data), 6 joints",
    ),
}


def known_arms() -> tuple[str, ...]:
    """Names accepted by `load_arm`."""
    return tuple(ARMS)


def example_robot_data_dir() -> Path:
    """The `robots` directory of the installed example-robot-data package, or a RobotError."""
    candidates = []
    try:
        dist = importlib.metadata.distribution("example-robot-data")
        candidates.append(Path(str(dist.locate_file("cmeel.prefix/share/example-robot-data/robots"))))
    except importlib.metadata.PackageNotFoundError:
        pass
    for key in ("purelib", "platlib"):
        candidates.append(Path(sysconfig.get_paths()[key]) / "cmeel.prefix/share/example-robot-data/robots")
    for c in candidates:
        if c.is_dir():
            return c
    raise RobotError(
        "example-robot-data is not installed (no cmeel.prefix/share/example-robot-data/robots in "
        f"{', '.join(str(c) for c in candidates)}); install it with `pip install example-robot-data`, "
        "or use the built-in arm 'pa10'"
    )


def urdf_path(name: str) -> Path:
    """The URDF file of the known arm `name`."""
    spec = _spec(name)
    if spec.urdf.startswith("erd:"):
        path = example_robot_data_dir() / spec.urdf[4:]
    else:
        path = URDF_DIR / spec.urdf
    if not path.is_file():
        raise RobotError(f"the URDF of arm '{name}' is missing: {path}")
    return path


def _spec(name: str) -> ArmSpec:
    try:
        return ARMS[name]
    except (KeyError, TypeError):
        raise RobotError(f"unknown arm {name!r}; known arms: {', '.join(ARMS)}") from None


def _offset(kind: str, value: float | None) -> float:
    v = DEFAULT_FRAME_OFFSETS[kind] if value is None else float(value)
    if not np.isfinite(v) or not 0.0 <= v <= 1.0:
        raise RobotError(f"{kind}_offset must be between 0 and 1 m beyond the flange, got {value}")
    return v


def load_arm(
    name: str = "pa10",
    *,
    marker_offset: float | None = None,
    ball_offset: float | None = None,
    acceleration_limit: ArrayLike | None = None,
    jerk_limit: ArrayLike | None = None,
) -> ArmModel:
    """Load a known arm ("pa10", "panda", "ur5") as an ArmModel with the named frames.

    `marker_offset`, `ball_offset`: distance (m) of the `marker` and `ball` frames beyond the flange
    along its z axis (defaults 0.10 and 0.15). `acceleration_limit` (rad/s^2) and `jerk_limit`
    (rad/s^3): per joint (or one value for all) instead of the arm's defaults.
    Raises RobotError for an unknown arm, a missing example-robot-data or bad settings.
    """
    spec = _spec(name)
    offsets = {"marker": _offset("marker", marker_offset), "ball": _offset("ball", ball_offset)}
    path = urdf_path(name)
    full = pin.buildModelFromUrdf(str(path))
    model = _lock_extra_joints(full, len(spec.home))
    _rename_conflicting_frames(model)
    _add_named_frames(model, spec.flange_source, offsets)

    names = tuple(model.names[1:])
    vel = np.array(model.velocityLimit, dtype=float)
    acc = np.asarray(spec.acceleration if spec.acceleration is not None else vel / ACCEL_TIME, dtype=float)
    if acceleration_limit is not None:
        acc = np.asarray(acceleration_limit, dtype=float)
    jerk = np.asarray(spec.jerk if spec.jerk is not None else np.asarray(acc) / JERK_TIME, dtype=float)
    if jerk_limit is not None:
        jerk = np.asarray(jerk_limit, dtype=float)
    limits = JointLimits(
        names=names,
        lower=np.array(model.lowerPositionLimit, dtype=float),
        upper=np.array(model.upperPositionLimit, dtype=float),
        velocity=vel,
        acceleration=acc,
        jerk=jerk,
    )
    return ArmModel(name, model, limits, np.array(spec.home), urdf_path=path, frame_offsets=offsets)


def _lock_extra_joints(model: pin.Model, n_arm: int) -> pin.Model:
    """Lock every joint after the first `n_arm` (grippers) at its neutral position (Panda: closed)."""
    if model.njoints - 1 == n_arm:
        return model
    if model.njoints - 1 < n_arm:
        raise RobotError(f"URDF has {model.njoints - 1} joints, expected at least {n_arm}")
    lock = list(range(n_arm + 1, model.njoints))
    return pin.buildReducedModel(model, lock, pin.neutral(model))


def _rename_conflicting_frames(model: pin.Model) -> None:
    """A URDF frame called `base` that is not the root (the UR5's) is renamed `urdf:base`.

    (`link1`, `marker`, `ball` are checked in `_add_named_frames`.)
    """
    for f in model.frames:
        if f.name == "base" and not (f.parentJoint == 0 and f.placement.isIdentity()):
            f.name = "urdf:base"


def _add_frame(model: pin.Model, name: str, joint: int, parent_frame: int, placement: pin.SE3) -> None:
    model.addFrame(pin.Frame(name, joint, parent_frame, placement, pin.FrameType.OP_FRAME), False)


def _add_named_frames(model: pin.Model, flange_source: str, offsets: dict[str, float]) -> None:
    """Add `base`, `link1`, `flange`, `marker`, `ball` where missing (placements relative to joints)."""
    if not model.existFrame("base"):
        _add_frame(model, "base", 0, 0, pin.SE3.Identity())
    # link1: on joint 1, equal to the world frame at q = 0: placement in joint 1 = (oMi_1(q = 0))^-1,
    # so that its placement in base is oMi_1(q) oMi_1(0)^-1 = Rz(q1) for a vertical joint 1 through
    # the base origin. The PA-10's URDF link `link1` is already that frame.
    data = model.createData()
    pin.forwardKinematics(model, data, pin.neutral(model))
    wanted = data.oMi[1].inverse()
    existing = model.frames[model.getFrameId("link1")] if model.existFrame("link1") else None
    if existing is None or existing.parentJoint != 1 or not existing.placement.isApprox(wanted):
        if existing is not None:
            existing.name = "urdf:link1"
        _add_frame(model, "link1", 1, 0, wanted)
    if not model.existFrame(flange_source):
        raise RobotError(f"the URDF has no frame {flange_source!r} to use as the flange")
    src = model.frames[model.getFrameId(flange_source)]
    if flange_source != "flange":
        _add_frame(model, "flange", src.parentJoint, model.getFrameId(flange_source), src.placement)
    fl = model.frames[model.getFrameId("flange")]
    for kind in ("marker", "ball"):
        if model.existFrame(kind):
            model.frames[model.getFrameId(kind)].name = "urdf:" + kind
        offset = pin.SE3(np.eye(3), np.array([0.0, 0.0, offsets[kind]]))
        _add_frame(model, kind, fl.parentJoint, model.getFrameId("flange"), fl.placement * offset)
