"""The catalogue of arms and `load_arm`: an `ArmSpec` -> URDF -> Pinocchio model -> `ArmModel` with named frames.

Known arms: the specs shipped in robot/specs/ (`wiithrow.robot.spec`): "pa10" (the project's own
URDF, robot/urdf/pa10.urdf), "panda" (example-robot-data's URDF, Franka's published limits),
"ur5e" (the project's URDF from Universal Robots' published DH table, robot/urdf/ur5e.urdf) and
"ur5" (example-robot-data's UR5). Any other arm comes from a spec in the settings
(`load_arm(ArmSpec.from_dict(...))`): no editing of the package.

Every arm gets the same named frames (added as Pinocchio OP_FRAMEs where the URDF lacks them):
- `base`: the root, z up; it is Pinocchio's world frame, so every position is in `base`.
  A URDF frame already called `base` with another meaning (the UR5's ROS-Industrial `base`,
  turned by pi about z) is renamed to `urdf:base`.
- `link1`: attached to joint 1 (the spec's `joint1`, which must be the URDF's first joint,
  vertical through the base origin: checked here) and equal to `base` at q1 = 0, so it is `base`
  turned by q1 about z. Its plane y = 0 is the throw plane; its (x, z) are distance and height.
- `flange`: the tool flange, z pointing out of the hand (the spec's `flange`: PA-10 DH frame 7;
  Panda panda_link8; UR tool0).
- `marker` (the IR LED held by the hand for calibration) and `ball` (where the ball sits before
  release): the flange translated along its z axis by `marker_offset` (default: the spec's,
  0.10 m) and `ball_offset` (0.15 m), same orientation as the flange.

Grippers are locked (Panda fingers closed), so q holds the arm's joints only.

Acceleration and jerk limits left out of a spec follow the time-to-full-speed rule
    t = v/a + a/j = 0.15 s + 0.075 s = 0.225 s   (a = v / 0.15 s, j = a / 0.075 s),
which lets the elbow and wrist reach full speed within the 0.2-0.5 s of a throw's acceleration
phase. The PA-10's are this rule rounded; the Panda's are Franka's published figures; the UR5e's
follow the rule (Universal Robots publish no joint acceleration limits: the arm is torque-limited).
"""

from __future__ import annotations

import importlib.metadata
import sysconfig
import xml.etree.ElementTree as ET
from functools import cache
from pathlib import Path
from types import MappingProxyType

import numpy as np
import pinocchio as pin
from numpy.typing import ArrayLike

from wiithrow.native_stderr import captured_stderr
from wiithrow.robot.errors import RobotError
from wiithrow.robot.limits import JointLimits
from wiithrow.robot.model import ArmModel
from wiithrow.robot.spec import URDF_DIR, ArmSpec, check_joint_figures, shipped_specs

__all__ = ["URDF_DIR", "ArmSpec", "known_arms", "load_arm", "spec_of", "urdf_path"]

#: Default offsets (m) of the named tool frames beyond the flange, along the flange z axis.
DEFAULT_FRAME_OFFSETS = MappingProxyType({"marker": 0.10, "ball": 0.15})

#: The time-to-full-speed rule of the default acceleration and jerk limits (see the module docstring).
ACCEL_TIME = 0.15  # s: a = v / ACCEL_TIME
JERK_TIME = 0.075  # s: j = a / JERK_TIME


@cache
def _shipped() -> MappingProxyType[str, ArmSpec]:
    return MappingProxyType(shipped_specs())


def known_arms() -> tuple[str, ...]:
    """Names of the shipped arms, accepted by `load_arm`."""
    return tuple(_shipped())


def spec_of(arm: str | ArmSpec) -> ArmSpec:
    """The spec of a shipped arm by name (or `arm` itself if it is a spec); RobotError for an unknown name."""
    if isinstance(arm, ArmSpec):
        return arm
    try:
        return _shipped()[arm]
    except (KeyError, TypeError):
        raise RobotError(
            f"unknown arm {arm!r}; known arms: {', '.join(_shipped())} (or define one by its spec: docs/robot.md)"
        ) from None


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


def urdf_path(arm: str | ArmSpec) -> Path:
    """The URDF file of the arm (a shipped arm's name, or a spec)."""
    return spec_of(arm).urdf_file()


def _offset(kind: str, value: float | None, default: float) -> float:
    v = default if value is None else float(value)
    if not np.isfinite(v) or not 0.0 <= v <= 1.0:
        raise RobotError(f"{kind}_offset must be between 0 and 1 m beyond the flange, got {value}")
    return v


def load_arm(
    arm: str | ArmSpec = "pa10",
    *,
    marker_offset: float | None = None,
    ball_offset: float | None = None,
    acceleration_limit: ArrayLike | None = None,
    jerk_limit: ArrayLike | None = None,
) -> ArmModel:
    """Load an arm, a shipped one by name ("pa10", "panda", "ur5e", "ur5") or any by its `ArmSpec`,
    as an ArmModel with the named frames (its `spec` attribute is the spec).

    `marker_offset`, `ball_offset`: distance (m) of the `marker` and `ball` frames beyond the flange
    along its z axis (defaults: the spec's). `acceleration_limit` (rad/s^2) and `jerk_limit`
    (rad/s^3): per joint (or one value for all) instead of the spec's.
    Raises RobotError for an unknown arm, a missing URDF or example-robot-data, or bad settings.
    """
    spec = spec_of(arm)
    offsets = {
        "marker": _offset("marker", marker_offset, spec.marker_offset),
        "ball": _offset("ball", ball_offset, spec.ball_offset),
    }
    path = spec.urdf_file()
    full = _build_from_urdf(spec.name, path)
    model = _lock_extra_joints(full, len(spec.home))
    _check_joint1(model, spec)
    _rename_conflicting_frames(model)
    _add_named_frames(model, spec.flange, offsets)

    names = tuple(model.names[1:])
    vel = np.array(spec.velocity if spec.velocity is not None else model.velocityLimit, dtype=float)
    acc = np.asarray(spec.acceleration if spec.acceleration is not None else vel / ACCEL_TIME, dtype=float)
    if acceleration_limit is not None:
        acc = np.asarray(acceleration_limit, dtype=float)
    jerk = np.asarray(spec.jerk if spec.jerk is not None else np.asarray(acc) / JERK_TIME, dtype=float)
    if jerk_limit is not None:
        jerk = np.asarray(jerk_limit, dtype=float)
    lower = np.array(spec.lower if spec.lower is not None else model.lowerPositionLimit, dtype=float)
    upper = np.array(spec.upper if spec.upper is not None else model.upperPositionLimit, dtype=float)
    limits = JointLimits(names=names, lower=lower, upper=upper, velocity=vel, acceleration=acc, jerk=jerk)
    figures = {key: getattr(limits, key) for key in ("lower", "upper", "velocity", "acceleration", "jerk")}
    try:  # the URDF's figures and the caller's, held to the spec's bounds
        check_joint_figures(figures, where=f"arm '{spec.name}' ({path.name} and its spec)")
    except RobotError as exc:
        raise RobotError(f"{exc}: give the figure in the arm's spec") from None
    return ArmModel(spec.name, model, limits, np.array(spec.home), urdf_path=path, frame_offsets=offsets, spec=spec)


def _build_from_urdf(name: str, path: Path) -> pin.Model:
    """Pinocchio's model of the URDF at `path`, else RobotError in one line. The file is parsed as
    XML first (a malformed one is named with its line and column); what urdfdom, Pinocchio's C++
    parser, writes to stderr is captured and becomes the error's detail (its own lines are not
    printed; on success they are written back)."""
    try:
        ET.parse(path)
    except ET.ParseError as exc:
        raise RobotError(f"arm '{name}': {path} is not well-formed XML: {exc}") from None
    except OSError as exc:
        raise RobotError(f"arm '{name}': cannot read {path}: {exc.strerror or exc}") from None
    try:
        with captured_stderr() as said:
            model = pin.buildModelFromUrdf(str(path))
    except (RuntimeError, ValueError) as exc:
        # urdfdom's lines are "Error:   <what>" then "at line N in <its source file>"
        what = [line.removeprefix("Error:").strip() for line in said.lines if not line.startswith("at line ")]
        detail = "; ".join(what) or " ".join(str(exc).split())
        raise RobotError(f"arm '{name}': {path} is not a URDF Pinocchio can read: {detail}") from None
    said.replay()
    return model


def _check_joint1(model: pin.Model, spec: ArmSpec) -> None:
    """The spec's joint 1 is the model's first joint, turning about the vertical through the base origin."""
    if model.names[1] != spec.joint1:
        raise RobotError(
            f"arm '{spec.name}': joint1 is {spec.joint1!r}, but the URDF's first joint is {model.names[1]!r}"
        )
    data = model.createData()
    pin.forwardKinematics(model, data, pin.neutral(model))
    J = pin.computeJointJacobian(model, data, pin.neutral(model), 1)  # LOCAL: the axis in joint 1's frame
    axis = data.oMi[1].rotation @ np.asarray(J[3:, 0])
    origin = data.oMi[1].translation
    if abs(abs(axis[2]) - 1.0) > 1e-9 or np.hypot(origin[0], origin[1]) > 1e-9:
        raise RobotError(
            f"arm '{spec.name}': joint 1 ({spec.joint1}) must turn about the vertical through the base origin "
            f"(axis {np.round(axis, 4).tolist()}, origin {np.round(origin, 4).tolist()} in base): "
            "link1, the throw plane and the rig's mount are turns of base about z"
        )


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
