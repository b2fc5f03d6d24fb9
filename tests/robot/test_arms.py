"""load_arm and the arm catalogue: the PA-10 URDF (limits, geometry, joints), the named frames of every
arm, the marker/ball offsets, the limit defaults, and the errors."""

from __future__ import annotations

import xml.etree.ElementTree as ET

import numpy as np
import pytest

from wiithrow.robot import DEFAULT_FRAME_OFFSETS, NAMED_FRAMES, RobotError, known_arms, load_arm, urdf_path
from wiithrow.robot import arms as arms_module

# The manufacturer's limits of the PA-10, as docs/robot.md lists them: position +- (deg), velocity (rad/s).
PA10_LIMITS_DEG = (177, 91, 174, 137, 255, 165, 255)
PA10_VELOCITY = (1, 1, 2, 2, 6.2832, 6.2832, 6.2832)
PA10_JOINTS = ("S1", "S2", "S3", "E1", "E2", "W1", "W2")


def test_pa10_limits_are_the_documented_ones(pa10):
    assert pa10.joint_names == PA10_JOINTS
    assert pa10.nq == 7
    np.testing.assert_allclose(pa10.upper, np.radians(PA10_LIMITS_DEG), rtol=0, atol=1e-12)
    np.testing.assert_allclose(pa10.lower, -np.radians(PA10_LIMITS_DEG), rtol=0, atol=1e-12)
    np.testing.assert_array_equal(pa10.velocity_limit, PA10_VELOCITY)


def test_pa10_urdf_file_limits_are_the_documented_ones():
    root = ET.parse(urdf_path("pa10")).getroot()
    joints = {j.get("name"): j for j in root.iter("joint") if j.get("type") == "revolute"}
    assert tuple(joints) == PA10_JOINTS
    for name, deg, vel in zip(PA10_JOINTS, PA10_LIMITS_DEG, PA10_VELOCITY):
        lim = joints[name].find("limit")
        assert float(lim.get("upper")) == pytest.approx(np.radians(deg), abs=1e-12)
        assert float(lim.get("lower")) == pytest.approx(-np.radians(deg), abs=1e-12)
        assert float(lim.get("velocity")) == vel


def test_pa10_urdf_has_simple_geometry_and_plausible_inertia():
    root = ET.parse(urdf_path("pa10")).getroot()
    assert not list(root.iter("mesh"))
    total = 0.0
    for link in root.iter("link"):
        name = link.get("name")
        if name == "flange":
            continue
        assert link.find("visual/geometry/cylinder") is not None, name
        assert link.find("collision/geometry/cylinder") is not None, name
        m = float(link.find("inertial/mass").get("value"))
        I = link.find("inertial/inertia")
        ixx, iyy, izz = (float(I.get(k)) for k in ("ixx", "iyy", "izz"))
        assert m > 0 and min(ixx, iyy, izz) > 0
        # triangle inequality of principal moments, and the inertia of a body under 1 m
        assert ixx + iyy >= izz and iyy + izz >= ixx and ixx + izz >= iyy
        assert max(ixx, iyy, izz) < m * 1.0**2
        total += m
    assert 30.0 < total < 50.0  # a PA-10 weighs about 40 kg


def test_pa10_urdf_loads_in_yourdfpy_with_the_same_kinematics(pa10):
    yourdfpy = pytest.importorskip("yourdfpy")
    urdf = yourdfpy.URDF.load(str(urdf_path("pa10")), load_meshes=False, build_scene_graph=True)
    assert tuple(urdf.actuated_joint_names) == PA10_JOINTS
    q = np.array([0.3, 0.5, -0.2, 1.0, 0.7, 0.4, -1.1])
    urdf.update_cfg(q)
    T = urdf.get_transform("flange", "base")
    np.testing.assert_allclose(T, pa10.frame_placement(q, "flange"), atol=1e-9)


@pytest.mark.parametrize("name", ["pa10", "panda", "ur5", "ur5e"])
def test_known_arms_load_with_named_frames(name):
    arm = load_arm(name)
    assert arm.name == name
    for f in NAMED_FRAMES:
        assert f in arm.frame_names
    assert arm.nq == len(arm.joint_names) == len(arm.home)
    for v in (arm.lower, arm.upper, arm.velocity_limit, arm.acceleration_limit, arm.jerk_limit):
        assert v.shape == (arm.nq,)
    assert np.all(arm.acceleration_limit > 0) and np.all(arm.jerk_limit > 0)


def test_panda_fingers_are_locked():
    arm = load_arm("panda")
    assert arm.nq == 7
    assert all("finger" not in n for n in arm.joint_names)


def test_ur5_base_is_the_root_not_the_ros_base():
    arm = load_arm("ur5")
    np.testing.assert_allclose(arm.frame_placement(arm.home, "base"), np.eye(4), atol=1e-15)
    assert "urdf:base" in arm.frame_names  # the URDF's own `base` (turned by pi) is renamed
    T = arm.frame_placement(arm.home, "urdf:base")
    np.testing.assert_allclose(T[:3, :3], np.diag([-1.0, -1.0, 1.0]), atol=1e-9)


@pytest.mark.parametrize("name,flange_source", [("panda", "panda_link8"), ("ur5", "tool0")])
def test_flange_of_example_robot_data_arms(name, flange_source):
    arm = load_arm(name)
    rng = np.random.default_rng(0)
    q = rng.uniform(arm.lower, arm.upper)
    np.testing.assert_allclose(arm.frame_placement(q, "flange"), arm.frame_placement(q, flange_source), atol=1e-12)


@pytest.mark.parametrize("name", ["pa10", "panda", "ur5", "ur5e"])
def test_marker_and_ball_default_offsets(name):
    arm = load_arm(name)
    rng = np.random.default_rng(1)
    for q in rng.uniform(arm.lower, arm.upper, size=(5, arm.nq)):
        F = arm.frame_placement(q, "flange")
        for f in ("marker", "ball"):
            T = arm.frame_placement(q, f)
            np.testing.assert_allclose(T[:3, :3], F[:3, :3], atol=1e-12)
            np.testing.assert_allclose(T[:3, 3], F[:3, 3] + DEFAULT_FRAME_OFFSETS[f] * F[:3, 2], atol=1e-12)
    assert DEFAULT_FRAME_OFFSETS == {"marker": 0.10, "ball": 0.15}


def test_custom_offsets():
    arm = load_arm("pa10", ball_offset=0.2, marker_offset=0.05)
    assert arm.frame_offsets == {"marker": 0.05, "ball": 0.2}
    np.testing.assert_allclose(arm.frame_position(np.zeros(7), "ball"), [0, 0, 1.517], atol=1e-12)
    np.testing.assert_allclose(arm.frame_position(np.zeros(7), "marker"), [0, 0, 1.367], atol=1e-12)
    with pytest.raises(RobotError, match="ball_offset"):
        load_arm("pa10", ball_offset=-0.1)


def test_default_acceleration_and_jerk_let_the_throwing_joints_reach_full_speed(pa10):
    # time from rest to the velocity limit of a jerk-limited profile: v/a + a/j (when v >= a^2/j)
    v, a, j = pa10.velocity_limit, pa10.acceleration_limit, pa10.jerk_limit
    assert np.all(v >= a**2 / j)
    t_full = v / a + a / j
    assert np.all((t_full > 0.2) & (t_full < 0.3)), t_full
    for name in ("E1", "W1"):
        assert t_full[pa10.joint_names.index(name)] < 0.25


def test_limit_settings():
    arm = load_arm("pa10", acceleration_limit=3.0, jerk_limit=np.arange(1, 8) * 10.0)
    np.testing.assert_array_equal(arm.acceleration_limit, np.full(7, 3.0))
    np.testing.assert_array_equal(arm.jerk_limit, np.arange(1, 8) * 10.0)
    with pytest.raises(RobotError, match="acceleration limit must be > 0"):
        load_arm("pa10", acceleration_limit=[1, 1, 1, 0, 1, 1, 1])
    with pytest.raises(RobotError, match="7 values"):
        load_arm("pa10", jerk_limit=[1, 2])


def test_unknown_arm_lists_the_known_ones():
    assert known_arms() == ("pa10", "panda", "ur5", "ur5e")
    with pytest.raises(RobotError, match="unknown arm 'pa20'; known arms: pa10, panda, ur5, ur5e"):
        load_arm("pa20")


def test_missing_example_robot_data_gives_a_clear_error(monkeypatch, tmp_path):
    import importlib.metadata

    def not_found(name):
        raise importlib.metadata.PackageNotFoundError(name)

    monkeypatch.setattr(arms_module.importlib.metadata, "distribution", not_found)
    monkeypatch.setattr(
        arms_module.sysconfig, "get_paths", lambda: {"purelib": str(tmp_path), "platlib": str(tmp_path)}
    )
    with pytest.raises(RobotError, match="example-robot-data is not installed.*pip install example-robot-data"):
        load_arm("panda")
    load_arm("pa10")  # the built-in arm does not need it


def test_pa10_urdf_is_what_its_generator_writes():
    import importlib.util

    path = urdf_path("pa10")
    spec = importlib.util.spec_from_file_location("make_pa10", path.parent / "make_pa10.py")
    gen = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(gen)
    assert gen.urdf_text() == path.read_text()
