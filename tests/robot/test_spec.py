"""Arm specs (`wiithrow.robot.spec`): the shipped ones (the Panda's published limits, the UR5e's URDF
from UR's DH table), an arm defined by settings from its own URDF file, and one-line errors."""

from __future__ import annotations

import importlib.util
import json
import xml.etree.ElementTree as ET

import numpy as np
import pytest

from wiithrow.app.errors import AppError
from wiithrow.app.settings import Settings
from wiithrow.robot import NAMED_FRAMES, ArmSpec, RobotError, known_arms, load_arm, spec_of, urdf_path

# Franka's published joint limits (Franka Control Interface docs, "Robot and interface specifications")
PANDA_Q_MAX = (2.8973, 1.7628, 2.8973, -0.0698, 2.8973, 3.7525, 2.8973)
PANDA_Q_MIN = (-2.8973, -1.7628, -2.8973, -3.0718, -2.8973, -0.0175, -2.8973)
PANDA_DQ = (2.175, 2.175, 2.175, 2.175, 2.61, 2.61, 2.61)
PANDA_DDQ = (15, 7.5, 10, 12.5, 15, 20, 20)
PANDA_DDDQ = (7500, 3750, 5000, 6250, 7500, 10000, 10000)
# Universal Robots' published DH table of the UR5e (m, rad)
UR5E_D = (0.1625, 0, 0, 0.1333, 0.0997, 0.0996)
UR5E_A = (0, -0.425, -0.3922, 0, 0, 0)
UR5E_ALPHA = (np.pi / 2, 0, 0, np.pi / 2, -np.pi / 2, 0)


def dh_flange(q):
    """The UR5e's flange (tool0) in base by the standard DH chain T_i = Rz(q) Tz(d) Tx(a) Rx(alpha)."""
    T = np.eye(4)
    for qi, d, a, al in zip(q, UR5E_D, UR5E_A, UR5E_ALPHA):
        c, s, ca, sa = np.cos(qi), np.sin(qi), np.cos(al), np.sin(al)
        T = T @ np.array([[c, -s * ca, s * sa, a * c], [s, c * ca, -c * sa, a * s], [0, sa, ca, d], [0, 0, 0, 1]])
    return T


@pytest.mark.parametrize("name", ["pa10", "panda", "ur5", "ur5e"])
def test_shipped_specs_round_trip_through_json(name):
    spec = spec_of(name)
    again = ArmSpec.from_dict(json.loads(json.dumps(spec.to_dict())))
    assert again == spec
    assert load_arm(again).spec == spec


def test_panda_limits_are_frankas_published_ones():
    arm = load_arm("panda")
    np.testing.assert_array_equal(arm.upper, PANDA_Q_MAX)
    np.testing.assert_array_equal(arm.lower, PANDA_Q_MIN)
    np.testing.assert_array_equal(arm.velocity_limit, PANDA_DQ)
    np.testing.assert_array_equal(arm.acceleration_limit, PANDA_DDQ)
    np.testing.assert_array_equal(arm.jerk_limit, PANDA_DDDQ)
    # the URDF of example-robot-data agrees on positions and velocities
    root = ET.parse(urdf_path("panda")).getroot()
    limits = [j.find("limit") for j in root.iter("joint") if j.get("type") == "revolute"]
    assert [float(x.get("upper")) for x in limits] == list(PANDA_Q_MAX)
    assert [float(x.get("velocity")) for x in limits] == list(PANDA_DQ)
    assert "frankaemika.github.io/docs/control_parameters.html" in spec_of("panda").sources


def test_ur5e_urdf_is_what_its_generator_writes():
    path = urdf_path("ur5e")
    spec = importlib.util.spec_from_file_location("make_ur5e", path.parent / "make_ur5e.py")
    gen = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(gen)
    assert gen.urdf_text() == path.read_text()


def test_ur5e_kinematics_and_limits_are_universal_robots_published_ones():
    arm = load_arm("ur5e")
    rng = np.random.default_rng(3)
    for q in rng.uniform(-np.pi, np.pi, size=(20, 6)):
        np.testing.assert_allclose(arm.frame_placement(q, "flange"), dh_flange(q), atol=1e-12)
    np.testing.assert_allclose(arm.upper, 2 * np.pi)
    np.testing.assert_allclose(arm.lower, -2 * np.pi)
    np.testing.assert_allclose(arm.velocity_limit, np.pi)  # 180 degrees/s every joint
    # no published acceleration or jerk: the 0.225 s rule
    np.testing.assert_allclose(arm.acceleration_limit, np.pi / 0.15)
    np.testing.assert_allclose(arm.jerk_limit, np.pi / 0.15 / 0.075)
    masses = [float(x.get("value")) for x in ET.parse(urdf_path("ur5e")).getroot().iter("mass")]
    assert masses[1:] == [3.761, 8.058, 2.846, 1.37, 1.3, 0.365]  # UR's published link masses


def test_an_arm_defined_by_settings_from_its_own_urdf(tmp_path):
    # a lab's arm: its URDF file beside the settings, named by a relative path; no package edit
    (tmp_path / "lab_arm.urdf").write_text(urdf_path("ur5e").read_text())
    entry = spec_of("ur5e").to_dict() | {"name": "lab_ur", "urdf": "lab_arm.urdf", "velocity": [2.0] * 6}
    path = tmp_path / "lab.json"
    path.write_text(json.dumps({"kind": "wiithrow.settings", "schema": 1, "settings": {"arm_spec": entry}}))
    settings = Settings.load(path)
    assert settings.arm == "lab_ur" and "lab_ur" not in known_arms()
    arm = settings.load_arm()
    assert arm.name == "lab_ur" and arm.urdf_path == tmp_path / "lab_arm.urdf"
    assert all(f in arm.frame_names for f in NAMED_FRAMES)
    np.testing.assert_array_equal(arm.velocity_limit, np.full(6, 2.0))
    np.testing.assert_allclose(arm.acceleration_limit, 2.0 / 0.15)  # the rule, on the spec's velocity
    # saved and read back elsewhere, it still names the same file
    saved = Settings.from_dict(json.loads(json.dumps(settings.to_dict())))
    assert saved.load_arm().urdf_path == tmp_path / "lab_arm.urdf"


@pytest.mark.parametrize(
    "change,message",
    [
        ({"hom": [0]}, r"arm_spec: unknown key\(s\) \['hom'\]"),
        ({"velocity": [1.0, 2.0]}, "velocity must have 6 values"),
        ({"jerk": [1, 1, 1, 0, 1, 1]}, "every jerk limit must be > 0"),
        ({"joint1": "elbow_joint"}, "joint1 is 'elbow_joint', but the URDF's first joint is 'shoulder_pan_joint'"),
        ({"flange": "hand"}, "no frame 'hand' to use as the flange"),
        ({"urdf": "nowhere/arm.urdf"}, "the URDF of arm 'lab' is missing"),
        ({"ball_offset": 2.0}, "ball_offset must be a number from 0 to 1 m"),
        ({"throwing": {"joints": ["elbow_joint"]}}, r"missing key\(s\) \['throwing.held'"),
    ],
)
def test_bad_arm_specs_are_refused_in_one_line(change, message, tmp_path):
    entry = spec_of("ur5e").to_dict() | {"name": "lab"} | change
    with pytest.raises((AppError, RobotError), match=message) as err:
        Settings.from_dict({"arm_spec": entry}, base_dir=str(tmp_path)).load_arm()
    assert "\n" not in str(err.value)


def test_a_missing_key_and_a_name_conflict_are_named():
    with pytest.raises(AppError, match=r"arm_spec: missing key\(s\) \['urdf', 'joint1', 'flange', 'home'\]"):
        Settings.from_dict({"arm_spec": {"name": "x"}})
    with pytest.raises(AppError, match="arm is 'pa10' but arm_spec defines 'lab'"):
        Settings.from_dict({"arm": "pa10", "arm_spec": spec_of("ur5e").to_dict() | {"name": "lab"}})
    # a library trained for a shipped arm must not pass for another arm of the same name
    with pytest.raises(AppError, match="arm_spec is named 'pa10', a shipped arm's name: give your arm its own name"):
        Settings.from_dict({"arm_spec": spec_of("ur5e").to_dict() | {"name": "pa10"}})


def test_joint_1_must_turn_about_the_vertical_through_the_base_origin(tmp_path):
    text = (
        urdf_path("ur5e")
        .read_text()
        .replace('<origin xyz="0 0 0" rpy="0 0 0"/>', '<origin xyz="0.1 0 0" rpy="0 0 0"/>', 1)
    )
    (tmp_path / "offset.urdf").write_text(text)
    spec = ArmSpec.from_dict(spec_of("ur5e").to_dict() | {"urdf": "offset.urdf"}, base_dir=str(tmp_path))
    with pytest.raises(
        RobotError, match=r"joint 1 \(shoulder_pan_joint\) must turn about the vertical through the base"
    ):
        load_arm(spec)
