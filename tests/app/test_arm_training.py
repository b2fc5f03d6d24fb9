"""The Panda and the UR5e train (the paper's 25 throws, labelled by the rig) and throw in the
kinematic world. The UR5e comes in as a lab's arm would: defined in the settings (`arm_spec`).

Bound: the median true landing error of six throws to seeded targets inside the arm's trained area
is <= 10 mm (measured: Panda 2.2 mm, UR5e 1.8 mm), none beyond 40 mm (Panda 15 mm); the issue's
MuJoCo goal is <= 20 mm (tests/app/test_mujoco_arms.py). Each training takes 15-50 s of the machine."""

from __future__ import annotations

import numpy as np
import pytest

from wiithrow.app.rig.waiting import pump
from wiithrow.app.settings import Settings
from wiithrow.app.throws.execution import execute_throw, planning_start
from wiithrow.app.throws.training import train_in_world
from wiithrow.app.worlds.simulated import SimWorld
from wiithrow.robot import spec_of
from wiithrow.throwing import ThrowPlanner, leave_one_out_error
from wiithrow.throwing.arm_throwing import shape_for, training_area

SETTINGS = {
    "panda": Settings(arm="panda"),
    "ur5e": Settings.from_dict({"arm_spec": spec_of("ur5e").to_dict() | {"name": "lab_ur5e"}}),
}


@pytest.mark.parametrize("name", sorted(SETTINGS))
def test_an_arm_trains_and_throws_in_the_kinematic_world(name):
    world = SimWorld(SETTINGS[name], seed=3)
    world.set_calibration(world.true_calibration())
    world.connect()
    pump(world.clock, world.rig, 0.2, step_s=0.001)
    arm = world.arm_model
    library = train_in_world(world, np.random.default_rng(0))  # the 5 x 5 grid over the spec's area
    assert len(library) == 25 and library.arm == arm.name and library.shape == shape_for(arm)
    area = training_area(arm)
    x, z = library.targets[:, 0], library.targets[:, 1]
    assert abs(x.min() - area.x[0]) < 0.05 and abs(x.max() - area.x[1]) < 0.05 and z.max() == area.z[1]
    assert leave_one_out_error(library, arm).median < 0.01

    planner = ThrowPlanner(arm, library)
    rng = np.random.default_rng(11)
    errors = []
    for _ in range(6):
        target = np.array([rng.uniform(area.x[0] + 0.05, area.x[1] - 0.05), rng.uniform(area.z[0], area.z[1] - 0.05)])
        pump(world.clock, world.rig, 0.05, step_s=0.001)
        q = planning_start(world)
        throw = planner.plan(target, q1=float(q[0]), q_start=q)
        done = execute_throw(world, throw, surface_height=float(target[1]))
        errors.append(float(np.hypot(done.landing_link1[0] - target[0], done.landing_link1[1])))
    assert np.median(errors) <= 0.010, errors
    assert max(errors) <= 0.040, errors
