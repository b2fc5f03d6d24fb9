"""Settings of the running system: the arm, the rig on link 1, noise, the ball. Versioned JSON.

Every number the simulated world is built from lives here (docs/simulation.md, "The default world"):
a PA-10 at the origin of `base`; two Wiimotes on `link1` 0.25 m apart along y near shoulder
height, pitched down a little so that the calibration volume in front of the arm and targets on
the floor or a table at 1-2.5 m are in their common field of view; pixel noise 0.5 px, release-time
jitter 2 ms, joint tracking error 1 mrad. A settings file may give any subset; the rest keeps its
default. Unknown keys are an error (a typo must not silently fall back to a default), and so is
every number that is not a finite number within the range its field states (`number(default, low,
high, unit)`, inclusive: a NaN baseline, a negative mass, 2.5 remotes), and a string where a
number belongs: one line naming the key (`rig.baseline`) and the range.

The `*_driver` settings name code that `wiithrow serve` imports and runs (`module:factory`, like a
Python import): a settings file is trusted input, to be taken only from its user
(docs/bring-up/settings.md, "Settings files run code").
"""

from __future__ import annotations

import dataclasses
import math
import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from wiithrow.app.errors import AppError
from wiithrow.app.mjcf_settings import MjcfSettings
from wiithrow.robot import ArmModel, ArmSpec, RobotError, known_arms, load_arm
from wiithrow.vision.errors import VisionError
from wiithrow.vision.files import SETTINGS_SIZE, read_versioned_json, write_versioned_json
from wiithrow.vision.wiimote.protocol import IRFormat, sensitivity_blocks

FILE_KIND = "wiithrow.settings"
SCHEMA = 1
#: How many remotes a rig may have.
CAMERA_COUNTS = (2, 3, 4)
#: Where three or four remotes in a row turn to when the settings do not say (`Settings.with_cameras`).
DEFAULT_CONVERGE_M = 1.0


Bound = float | tuple[float, ...]


def number(default: Any, low: Bound, high: Bound, unit: str = "") -> Any:
    """A numeric setting (a number, or a tuple of them) and the range a file may give it: low to
    high inclusive, for every component (a tuple `low`/`high`: one bound per component)."""
    return field(default=default, metadata={"range": (low, high), "unit": unit})


def choice(default: str, choices: tuple[str, ...]) -> Any:
    """A setting that is one of `choices` (a file giving another is one line naming them)."""
    return field(default=default, metadata={"choices": choices})


@dataclass(frozen=True)
class RigSettings:
    """The nominal stereo rig: cameras side by side along y of `link1`, looking along +x."""

    # Measured (wiithrow.app.calibration.poses.rig_coverage, wiithrow.app.throws.area_view; docs/
    # simulation.md, "The rig"): with f = 1300 px the vertical field of view is only 33 degrees. From
    # 5 cm behind joint 1's axis, 0.35 m up, the floor at x 0.9 m (the shipped training areas' near
    # edge, 1 m, with the 10 cm margin the area check adds) and a 0.5 m table at 1 m span 28 degrees,
    # centred 6 degrees below the horizon: this rig sees all of x 1-2.5 m, z 0-0.5 m in the throw
    # plane 20 px inside both images, every shipped area with its margin (33 px to spare), and the
    # hand's LED (facing the rig) at x 0.45-0.83 m, z 0.06-0.49 m, y +-0.18 m. At x 0.10 m it missed
    # the areas' near edge at the floor; pitched 15 degrees down it loses the table tops.
    center: tuple[float, float, float] = number((-0.05, 0.0, 0.35), -3.0, 3.0, "m")  # in link1
    baseline: float = number(0.25, 0.01, 2.0, "m")  # between neighbouring cameras
    count: int = number(2, 2, 4)  # remotes in the row
    # > 0: each remote turned about z towards the point this far ahead of `center` (m), so that
    # three or four remotes in a row share a view; 0: all look along +x (the two-remote default)
    converge_m: float = number(0.0, 0.0, 20.0, "m")
    pitch_down_deg: float = number(6.0, -90.0, 90.0, "degrees")
    focal_px: float = number(1300.0, 10.0, 100_000.0, "px")
    center_px: tuple[float, float] = number((512.0, 384.0), 0.0, (1024.0, 768.0), "px")  # in the 1024 x 768 image
    ir_format: str = "extended"
    sensitivity: str = "level3"


@dataclass(frozen=True)
class NoiseSettings:
    pixel_sigma_px: float = number(0.5, 0.0, 20.0, "px")  # before rounding to integer pixels
    release_jitter_s: float = number(0.002, 0.0, 0.1, "s")
    joint_tracking_rad: float = number(0.001, 0.0, 0.1, "rad")
    # The kinematic world's ball leaves the hand this far beside the throw plane (m, along link1's
    # +y at the release: a ball held off-centre), so that every throw lands that far to one side:
    # a steady sideways miss, what the learned sideways correction takes away (0.015: the
    # developers' test world). Within 0.1 m: a hand that misses by more does not hold a ball.
    release_across_m: float = number(0.0, -0.1, 0.1, "m")


@dataclass(frozen=True)
class BallSettings:
    """A tennis-like ball; its `ball` frame sits `offset` beyond the flange."""

    mass_kg: float = number(0.057, 0.001, 10.0, "kg")
    radius_m: float = number(0.033, 0.001, 0.5, "m")
    drag_coefficient: float = number(0.55, 0.0, 2.0)
    air_density: float = number(1.2, 0.0, 10.0, "kg/m^3")
    offset_m: float = number(0.15, 0.0, 1.0, "m")


@dataclass(frozen=True)
class MujocoSettings:
    """The MuJoCo world (`wiithrow.app.worlds.mujoco`; docs/simulation.md, "The MuJoCo world").

    The arm is the URDF's with seeded manufacturing tolerances (each joint origin moved by
    N(0, sigma^2) per coordinate, each joint's zero turned by N(0, sigma^2)), so the nominal
    kinematics the planner and the calibration use are slightly wrong, as on a real arm. Its servo
    is the PA-10's velocity mode: the host sends v = v_ref + K_p (q_ref - q) every millisecond, the
    amplifier closes a PI velocity loop per joint (bandwidth below, integral corner a fifth of it)
    and saturates at the torque limits. The hand opens `release_latency_s` (+ N(0, jitter^2)) after
    it is told to. After a throw a marker is put where the ball first touched down, off by
    N(0, placement_sigma_m^2) in each horizontal direction, and the rig measures it.
    """

    seed: int = number(0, 0, 2**32 - 1)  # the manufacturing tolerances and the world's other draws
    timestep_s: float = number(0.001, 1e-5, 0.01, "s")  # MuJoCo's step = the servo period (1 kHz)
    link_length_sigma_m: float = number(0.001, 0.0, 0.05, "m")
    joint_offset_sigma_rad: float = number(0.002, 0.0, 0.1, "rad")
    # the amplifier's PI velocity loop (estimate; docs/simulation.md)
    velocity_bandwidth_hz: float = number(25.0, 0.1, 1000.0, "Hz")
    position_gain_per_s: float = number(25.0, 0.0, 1000.0, "1/s")  # the host's position loop, K_p (estimate)
    release_latency_s: float = number(0.010, 0.0, 1.0, "s")
    release_jitter_s: float = number(0.003, 0.0, 0.1, "s")
    grip_force_n: float = number(20.0, 0.0, 1000.0, "N")
    placement_sigma_m: float = number(0.005, 0.0, 0.5, "m")
    # where the operator put the IR target in `wiithrow serve` over MuJoCo (m, base); the demo's by default
    target_base: tuple[float, float, float] = number((1.274, 0.258, 0.2), -10.0, 10.0, "m")
    # the arm's servo in the project's model (`wiithrow.app.worlds.mujoco.arm_servo`): the PA-10's
    # amplifier (PI velocity loops driving torques), or a joint PD on position setpoints without
    # gravity compensation, K_p = J (2 pi pd_bandwidth_hz)^2, K_d = K_p pd_lag_s (raw setpoints
    # lag a moving reference by pd_lag_s). A lab's MJCF states its own actuators.
    arm_servo: str = choice("pi_velocity", ("pi_velocity", "pd_position"))
    pd_bandwidth_hz: float = number(10.0, 0.1, 1000.0, "Hz")
    pd_lag_s: float = number(0.09, 0.0, 1.0, "s")
    # what the shipped arm driver adds to a PD servo's setpoints (`robot.feedforward`): nothing (raw
    # setpoints), the velocity term K_d v_ref / K_p, or that and the inverse dynamics tau / K_p
    feedforward: str = choice("none", ("none", "velocity", "inverse_dynamics"))


@dataclass(frozen=True)
class Settings:
    # The arm: a shipped arm's name ("pa10", "panda", "ur5e", "ur5": robot/specs/), or the name of
    # `arm_spec`, an arm defined here (a JSON object: its URDF, joint 1, flange, limits, throwing
    # joints; `wiithrow.robot.spec.ArmSpec`, docs/robot.md "Adding an arm"; a relative URDF path is
    # taken from the settings file's folder). Given `arm_spec` alone, `arm` is its name.
    arm: str = "pa10"
    arm_spec: ArmSpec | None = field(default=None, metadata={"object": "wiithrow.robot.spec.ArmSpec"})
    marker_offset_m: float = number(0.10, 0.0, 1.0, "m")  # the calibration LED, beyond the flange
    # The real arm's driver for `wiithrow serve`: "module:factory", factory(model, clock) -> a
    # `wiithrow.robot.interface.Arm`. Empty: no driver (the remotes track, the arm stays parked).
    arm_driver: str = ""
    # The hand's driver: "module:factory", factory(model, clock, settings) -> a
    # `wiithrow.robot.gripper.Gripper`. Empty: no gripper (a throw is refused on real hardware).
    gripper_driver: str = ""
    # The hand's close and open times (s; 0: not stated), as the lab measured them (`wiithrow.robot.
    # hand_timing.measure_close_time` / `measure_open_time`): a load waits for the grip up to twice
    # the close time (`wiithrow.app.worlds.grip`); `wiithrow check-driver` holds the hand to them.
    hand_close_s: float = number(0.0, 0.0, 10.0, "s")
    hand_open_s: float = number(0.0, 0.0, 10.0, "s")
    # How long before the planned release the throw tells the hand to open (s; 0: at the release):
    # the hand's latency and twice its jitter (what `wiithrow check-driver` measures of it), so that
    # the ball leaves on the smooth end of the wind-up, where a millisecond of the hand's delay moves
    # the landing a fraction of a millimetre, not in the follow-through's brake, where it moves it
    # about ten (docs/robot.md, "The hand and the release").
    hand_open_lead_s: float = number(0.0, 0.0, 0.1, "s")
    # The remotes' driver: "module:factory", factory(cameras, clock, settings) -> one
    # `WiimoteDriver` per camera. Empty: the Wiimotes hidapi finds.
    remotes_driver: str = ""
    # The folder of the arm's throw library: every version of it and the one in use (a relative
    # path is taken from this file's folder). Empty: beside the calibration a command measures with
    # (`wiithrow.app.session.library_folder`).
    library_folder: str = ""
    rig: RigSettings = field(default_factory=RigSettings)
    noise: NoiseSettings = field(default_factory=NoiseSettings)
    ball: BallSettings = field(default_factory=BallSettings)
    mujoco: MujocoSettings = field(default_factory=MujocoSettings)
    # A lab's own MuJoCo model as the MuJoCo world's physics (`wiithrow.app.mjcf_settings`: the MJCF
    # file, in the settings file's folder, and its joints, actuators, hand and sites mapped onto
    # the arm spec); None: the project's model, built from the arm's URDF.
    mjcf: MjcfSettings | None = field(default=None, metadata={"object": "wiithrow.app.mjcf_settings.MjcfSettings"})

    def to_dict(self) -> dict[str, Any]:
        out = dataclasses.asdict(dataclasses.replace(self, arm_spec=None, mjcf=None))
        out["arm_spec"] = None if self.arm_spec is None else self.arm_spec.to_dict()
        out["mjcf"] = None if self.mjcf is None else self.mjcf.to_dict()
        return out

    @classmethod
    def from_dict(cls, data: dict[str, Any], *, source: str = "settings", base_dir: str = "") -> Settings:
        """Settings from a (partial) dict; unknown keys raise AppError naming them. `base_dir`: the
        folder a relative URDF path of `arm_spec` is taken from (the settings file's)."""
        given: Any = data  # a file's JSON: not necessarily an object (then _build says so)
        if not isinstance(given, dict) or not {"arm_spec", "mjcf"} & set(given):
            return _build(cls, data, source)
        mjcf = None
        if data.get("mjcf") is not None:
            mjcf = MjcfSettings.from_dict(data["mjcf"], base_dir=base_dir, source=source)
        data = {k: v for k, v in data.items() if k != "mjcf"}
        if "arm_spec" not in data:
            return dataclasses.replace(_build(cls, data, source), mjcf=mjcf)
        rest = {k: v for k, v in data.items() if k != "arm_spec"}
        raw = data["arm_spec"]
        spec = None
        if raw is not None:
            try:
                spec = ArmSpec.from_dict(raw, base_dir=base_dir, source=f"{source}: arm_spec")
            except RobotError as exc:
                raise AppError(str(exc)) from None
            if spec.name in known_arms():  # a library trained for the shipped arm would pass for this one
                raise AppError(
                    f"{source}: arm_spec is named {spec.name!r}, a shipped arm's name: give your arm its own name"
                )
            name = rest.setdefault("arm", spec.name)
            if name != spec.name:
                raise AppError(
                    f"{source}: arm is {name!r} but arm_spec defines {spec.name!r}: give one name (or leave arm out)"
                )
        return dataclasses.replace(_build(cls, rest, source), arm_spec=spec, mjcf=mjcf)

    def load_arm(self) -> ArmModel:
        """The arm's kinematic model: `arm_spec` if given, else the shipped arm `arm`, with the
        marker and ball offsets of these settings (RobotError for an unknown arm or a bad URDF)."""
        return load_arm(
            self.arm_spec if self.arm_spec is not None else self.arm,
            marker_offset=self.marker_offset_m,
            ball_offset=self.ball.offset_m,
        )

    def save(self, path: str | os.PathLike[str]) -> Path:
        return write_versioned_json(path, FILE_KIND, SCHEMA, {"settings": self.to_dict()})

    @classmethod
    def load(cls, path: str | os.PathLike[str]) -> Settings:
        document = read_versioned_json(path, FILE_KIND, SCHEMA, SETTINGS_SIZE)
        return cls.from_dict(document.get("settings", {}), source=str(path), base_dir=str(Path(path).parent))

    def replace(self, **changes: Any) -> Settings:
        return dataclasses.replace(self, **changes)

    def with_cameras(self, count: int) -> Settings:
        """These settings with `count` remotes in the row (2 to 4; AppError otherwise). Three or four
        remotes side by side only share a view when they turn inwards: unless `rig.converge_m` says
        where to, they turn towards the point `DEFAULT_CONVERGE_M` ahead of the rig's centre."""
        if count not in CAMERA_COUNTS:
            raise AppError(f"a rig has 2 to 4 remotes, not {count}")
        converge = self.rig.converge_m if self.rig.converge_m > 0 or count == 2 else DEFAULT_CONVERGE_M
        return self.replace(rig=dataclasses.replace(self.rig, count=count, converge_m=converge))


def _build(cls: type, data: Any, source: str, prefix: str = "") -> Any:
    """An instance of the settings dataclass `cls` from the (partial) dict `data`; AppError
    "SOURCE: KEY ..." naming the first bad key (`prefix`: the dotted path to `cls`, e.g. "rig.")."""
    if not isinstance(data, dict):
        where = prefix.rstrip(".") or "the settings"
        raise AppError(f"{source}: expected an object for {where} ({cls.__name__}), got {type(data).__name__}")
    fields = {f.name: f for f in dataclasses.fields(cls)}
    unknown = sorted(set(data) - set(fields))
    if unknown:
        raise AppError(f"{source}: unknown {cls.__name__} setting(s) {unknown}; known: {sorted(fields)}")
    values = {}
    for name, value in data.items():
        key = prefix + name
        default = getattr(cls(), name)
        if dataclasses.is_dataclass(default):
            values[name] = _build(type(default), value, source, key + ".")
        elif "range" in fields[name].metadata:
            values[name] = _number(value, default, fields[name].metadata, f"{source}: {key}")
        elif isinstance(default, str):
            if not isinstance(value, str):
                raise AppError(f"{source}: {key} must be a string, got {value!r:.60}")
            choices = fields[name].metadata.get("choices")
            if choices is not None and value not in choices:
                raise AppError(f"{source}: {key} must be one of {', '.join(choices)}, got {value!r:.60}")
            values[name] = _choice(name, value, f"{source}: {key}")
        else:
            raise AppError(f"{source}: {key} cannot be set in a file")
    return cls(**values)


def _number(value: Any, default: Any, metadata: Any, where: str) -> Any:
    """`value` checked against `default`'s kind (a float, an int, a tuple of floats) and the
    field's range; AppError "WHERE must be ..." otherwise."""
    low, high = metadata["range"]
    unit = f" {metadata['unit']}" if metadata["unit"] else ""
    if isinstance(default, tuple):
        n = len(default)
        if not isinstance(value, list | tuple) or len(value) != n:
            raise AppError(f"{where} must be a list of {n} numbers, got {value!r:.60}")
        lows = low if isinstance(low, tuple) else (low,) * n
        highs = high if isinstance(high, tuple) else (high,) * n
        return tuple(
            _scalar(v, 0.0, lo, hi, unit, f"{where}[{i}]") for i, (v, lo, hi) in enumerate(zip(value, lows, highs))
        )
    assert not isinstance(low, tuple) and not isinstance(high, tuple), "a tuple bound is for a tuple setting"
    return _scalar(value, default, low, high, unit, where)


def _scalar(value: Any, default: float, low: float, high: float, unit: str, where: str) -> float:
    whole = isinstance(default, int) and not isinstance(default, bool)
    kind = "a whole number" if whole else "a number"
    span = f"from {low} to {high}{unit}" if whole else f"from {low:g} to {high:g}{unit}"
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise AppError(f"{where} must be {kind} {span}, got {value!r:.60}")
    if not math.isfinite(value) or not (low <= value <= high):
        raise AppError(f"{where} must be {kind} {span}, got {value!r}")
    if whole:
        if value != int(value):
            raise AppError(f"{where} must be {kind} {span}, got {value!r}")
        return int(value)
    return float(value)


def _choice(name: str, value: str, where: str) -> str:
    """The Wiimote's IR format and sensitivity by name: AppError for one the remote has not."""
    try:
        if name == "ir_format":
            IRFormat.from_name(value)
        elif name == "sensitivity":
            sensitivity_blocks(value)
    except VisionError as exc:
        raise AppError(f"{where}: {exc}") from None
    return value
