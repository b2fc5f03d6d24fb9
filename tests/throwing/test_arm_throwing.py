"""How each arm throws (`wiithrow.throwing.arm_throwing`): the throw shape from the arm's spec (the
PA-10's is the historical default), the UR5e's ball brought into the throw plane, and every arm's
training area reachable at the velocity margin."""

from __future__ import annotations

import math

import numpy as np
import pytest

from wiithrow.app.throws.library_file import load_library
from wiithrow.robot import ArmSpec, load_arm, spec_of
from wiithrow.throwing import (
    TRAINING_AREA,
    ThrowingError,
    ThrowShape,
    plan_throw,
    predict_landing,
    require_valid,
    solve_throw,
    training_targets,
)
from wiithrow.throwing.arm_throwing import nominal_release, shape_for, training_area
from wiithrow.throwing.operator import relative_speed

PITCH_JOINTS = {
    "pa10": ("S2", "E1", "W1"),
    "panda": ("panda_joint2", "panda_joint4", "panda_joint6"),
    "ur5e": ("shoulder_lift_joint", "elbow_joint", "wrist_1_joint"),
}
# the largest share of a velocity limit a trained corner needs (the operator's cap is 90 % x 95 %)
CORNER_SPEED = {"panda": 0.80, "ur5e": 0.72}


def test_the_pa10s_shape_area_and_pose_are_the_historical_defaults(pa10):
    assert shape_for(pa10) == ThrowShape()
    assert training_area(pa10) == TRAINING_AREA
    assert nominal_release(pa10) == (0.6, -0.4, -0.35)
    assert load_library().shape == shape_for(pa10)  # the shipped library is the PA-10's


@pytest.mark.parametrize("name", sorted(PITCH_JOINTS))
def test_the_throw_moves_the_arms_pitch_joints(name):
    arm = load_arm(name)
    shape = shape_for(arm)
    assert shape.moving_joints == PITCH_JOINTS[name]
    # every held joint and joint 1 is accounted for, and the ball stays in the throw plane
    rng = np.random.default_rng(2)
    mov, _, _ = shape.joint_layout(arm)
    for qm in rng.uniform(arm.lower[mov], arm.upper[mov], size=(10, 3)):
        q = shape.full_q(arm, qm, 0.4)
        assert abs(arm.to_frame(arm.frame_position(q, "ball"), q, "link1")[1]) < 1e-9


def test_the_ur5e_wrist_2_brings_the_ball_into_the_throw_plane():
    # the wrist is d4 = 0.1333 m off the shoulder's plane; the ball is d6 + 0.15 m along the tool
    # axis, which wrist 2 tilts out of the throw's plane by asin(d4 / (d6 + 0.15))
    arm = load_arm("ur5e")
    held = dict(shape_for(arm).held_joints)
    assert held["wrist_2_joint"] == pytest.approx(-math.pi / 2 - math.asin(0.1333 / (0.0996 + 0.15)), abs=1e-9)
    other = load_arm("ur5e", ball_offset=0.25)
    assert dict(shape_for(other).held_joints)["wrist_2_joint"] == pytest.approx(
        -math.pi / 2 - math.asin(0.1333 / (0.0996 + 0.25)), abs=1e-9
    )


@pytest.mark.parametrize("name", sorted(CORNER_SPEED))
def test_the_training_area_is_reachable_at_the_velocity_margin(name):
    arm = load_arm(name)
    shape = shape_for(arm)
    area = training_area(arm)
    mov, _, _ = shape.joint_layout(arm)
    speeds = []
    for target in training_targets(area, 2, 2):  # the four corners
        params = solve_throw(arm, target)
        speeds.append(relative_speed(arm, shape, params))
        landing = predict_landing(arm, shape, params, float(target[1]))
        assert np.hypot(landing.link1[0] - target[0], landing.link1[1]) < 1e-5
        throw = require_valid(plan_throw(arm, params, float(target[1]), target=target), arm)
        v = np.abs(throw.trajectory.velocities[:, mov]) / arm.velocity_limit[mov]
        assert v.max() <= 0.95 + 1e-9
    assert max(speeds) <= CORNER_SPEED[name], speeds


def test_an_arm_without_throwing_joints_or_with_a_joint_out_of_the_plane_is_refused():
    with pytest.raises(ThrowingError, match="arm 'ur5' has no throwing section"):
        shape_for(load_arm("ur5"))
    panda = spec_of("panda").to_dict()
    panda["throwing"] = panda["throwing"] | {
        "joints": ["panda_joint2", "panda_joint3", "panda_joint6"],
        "held": [["panda_joint4", -1.5], ["panda_joint5", 0.0], ["panda_joint7", 0.0]],
    }
    with pytest.raises(ThrowingError, match="off the throw plane .* must be pitch joints"):
        shape_for(load_arm(ArmSpec.from_dict(panda | {"name": "twisted"})))
