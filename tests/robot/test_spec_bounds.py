"""An arm's figures held to physical bounds, its URDF to its folder, and a target to the arm's
reach (docs/robot.md, "Limits"): each refused in one line naming the key; every shipped arm passes."""

from __future__ import annotations

import math

import numpy as np
import pytest

from wiithrow.robot import RobotError, known_arms, load_arm, spec_of, urdf_path
from wiithrow.robot.spec import MAX_JOINT_VELOCITY, ArmSpec
from wiithrow.throwing.errors import UnreachableTargetError
from wiithrow.throwing.reach import check_target_reach, throw_reach


def test_every_shipped_arm_is_within_the_bounds():
    for name in known_arms():
        arm = load_arm(name)  # the URDF's figures are checked as it loads
        assert 0 < arm.velocity_limit.max() <= MAX_JOINT_VELOCITY, name


@pytest.mark.parametrize(
    "change, needle",
    [
        ({"velocity": [1e9] * 6}, "lab: velocity[0] must be a number from 0 to 50 rad/s, got 1e+09"),
        ({"home": [0.0, 0.0, 0.0, 0.0, 0.0, 100.0]}, "lab: home[5] must be a number from -12.5664 to 12.5664 rad"),
        ({"lower": [1.0] * 6, "upper": [0.5] * 6}, "lab: lower[0] must be below upper[0], got 1 and 0.5"),
        (
            {"urdf": "wiithrow:../../etc/passwd"},
            "lab: urdf 'wiithrow:../../etc/passwd' leaves the package's URDF folder",
        ),
        ({"urdf": "example-robot-data:../../../x.urdf"}, "leaves example-robot-data's robots folder"),
        ({"urdf": "sub/../../arm.urdf"}, "lab: urdf 'sub/../../arm.urdf' is outside the settings file's folder"),
        ({"urdf": "~/arm.urdf"}, "lab: urdf '~/arm.urdf' is outside the settings file's folder"),
    ],
)
def test_a_spec_beyond_its_bounds_or_folder_is_one_line(tmp_path, change, needle):
    entry = spec_of("ur5e").to_dict() | {"name": "lab_ur"} | change
    with pytest.raises(RobotError) as err:
        ArmSpec.from_dict(entry, base_dir=str(tmp_path), source="lab")
    assert needle in str(err.value) and "\n" not in str(err.value), str(err.value)


def test_a_urdf_in_the_settings_folder_or_linked_there_is_taken(tmp_path):
    (tmp_path / "urdfs").mkdir()
    (tmp_path / "urdfs" / "arm.urdf").write_text(urdf_path("ur5e").read_text())
    elsewhere = tmp_path.parent / f"{tmp_path.name}_elsewhere.urdf"
    elsewhere.write_text(urdf_path("ur5e").read_text())
    (tmp_path / "linked.urdf").symlink_to(elsewhere)  # the allow rule: a link the lab made in its folder
    for urdf in ("urdfs/arm.urdf", str(tmp_path / "urdfs" / "arm.urdf"), "linked.urdf"):
        spec = ArmSpec.from_dict(spec_of("ur5e").to_dict() | {"name": "lab_ur", "urdf": urdf}, base_dir=str(tmp_path))
        assert load_arm(spec).nq == 6
    spec = ArmSpec.from_dict(spec_of("ur5e").to_dict() | {"name": "lab_ur", "urdf": str(elsewhere)})
    assert load_arm(spec).nq == 6  # a spec built in code (no settings file) names any path


def test_a_urdfs_own_figures_are_held_to_the_bounds(tmp_path):
    text = urdf_path("ur5e").read_text()
    assert 'velocity="3.141592653589793"' in text
    (tmp_path / "fast.urdf").write_text(text.replace('velocity="3.141592653589793"', 'velocity="1e9"', 1))
    spec = ArmSpec.from_dict(
        spec_of("ur5e").to_dict() | {"name": "lab_ur", "urdf": "fast.urdf"}, base_dir=str(tmp_path)
    )
    with pytest.raises(
        RobotError, match=r"arm 'lab_ur' \(fast.urdf and its spec\): velocity\[0\] must be a number from 0 to 50"
    ):
        load_arm(spec)


def test_a_target_no_throw_reaches_is_one_line(pa10):
    reach = throw_reach(pa10)
    assert 21 < reach.farthest_m(0.0) < 23  # the module docstring's PA-10 figure (21.8 m on the floor)
    check_target_reach(pa10, (1.3, 0.2, 0.0))  # the demo's neighbourhood
    for target, needle in (
        ((1e300, 0.0, 0.2), "the target (1e+300, 0, 0.2) m in base is beyond the reach of arm pa10"),
        ((1.0, 0.0, math.nan), "is not a position"),
        ((0.0, 30.0, 0.0), "30 m from joint 1's axis, and its throws land at most"),
        ((1.0, 0.0, -50.0), "its throws land between heights"),
    ):
        with pytest.raises(UnreachableTargetError) as err:
            check_target_reach(pa10, np.array(target))
        assert needle in str(err.value) and "\n" not in str(err.value), str(err.value)
