"""The Panda and the UR5e in the MuJoCo world built from their URDFs (issue 22 item 5): their
dynamics, the rig's mount on their link1, the hand turned across the throw plane, a training and
throws; and the one-line refusal of an arm whose URDF has no dynamics.

Bound of the throwing test (a small seeded version of the issue's goal, "median <= 20 mm over the
trained area" for 25 training throws): a 3 x 3 library (9 rig-labelled throws) over the spec's
area, then 4 throws to seeded targets inside it; the median true landing error is <= 30 mm and
none is beyond 60 mm, the rig-measured median <= 40 mm (measured, seed 3: true Panda 9.0 mm
median, 18 mm largest; UR5e 17.3 mm, 20 mm; rig-measured 9.2 and 14.0 mm; the full 25-throw figures
are in docs/simulation.md). Each arm takes 25-40 s of the machine."""

from __future__ import annotations

import dataclasses
import re

import mujoco
import numpy as np
import pytest

from wiithrow.app.errors import AppError
from wiithrow.app.rig.waiting import pump
from wiithrow.app.settings import Settings
from wiithrow.app.throws.execution import execute_throw, planning_start, return_home
from wiithrow.app.throws.training import train_in_world
from wiithrow.app.worlds.mujoco import params
from wiithrow.app.worlds.mujoco.lab import MujocoLab
from wiithrow.app.worlds.mujoco.model import build_model, check_arm, hand_turn
from wiithrow.app.worlds.mujoco.world import MujocoWorld
from wiithrow.clock import SimClock
from wiithrow.robot import spec_of, urdf_path
from wiithrow.throwing import ThrowPlanner, training_targets
from wiithrow.throwing.arm_throwing import shape_for, training_area

SETTINGS = {
    "panda": Settings(arm="panda"),
    # the UR5e as a lab's arm comes in: defined in the settings
    "ur5e": Settings.from_dict({"arm_spec": spec_of("ur5e").to_dict() | {"name": "lab_ur5e"}}),
}


@pytest.mark.parametrize("name", sorted(SETTINGS))
def test_the_arm_is_built_from_its_urdf_with_its_published_dynamics(name):
    built = build_model(SETTINGS[name])
    m, dyn = built.model, built.dynamics
    arm = SETTINGS[name].load_arm()
    assert built.joint_names == arm.joint_names and m.nu == arm.nq + 2  # a motor per joint, two fingers
    # the published torque limits are where the motors saturate
    expected = {"panda": (87.0,) * 4 + (12.0,) * 3, "ur5e": (150.0,) * 3 + (28.0,) * 3}[name]
    assert dyn.torque_limit_nm == expected
    assert np.allclose(m.actuator_ctrlrange[built.arm_ctrl, 1], expected)
    # the URDF's inertials are the links' (Panda: example-robot-data's; UR5e: UR's published masses)
    masses = m.body_mass[[mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, link) for link in dyn.links]]
    published = {
        "panda": (4.970684, 0.646926, 3.228604, 3.587895, 1.225946, 1.666555),  # links 1-6 (7 carries link8)
        "ur5e": (3.761, 8.058, 2.846, 1.37, 1.3, 0.365),
    }[name]
    assert np.allclose(masses[: len(published)], published)
    assert np.allclose(m.dof_armature[built.arm_dof], np.asarray(expected) / params.ROTOR_ACCELERATION)
    # the URDF's own hand and meshes are gone: the world's hand is on the flange
    assert m.nmesh == 0 and mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, "panda_hand") == -1
    assert mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, "palm") >= 0


@pytest.mark.parametrize("name", sorted(SETTINGS))
def test_the_rig_is_on_the_true_link1_and_the_fingers_close_across_the_throw_plane(name):
    settings = SETTINGS[name].replace(mujoco=dataclasses.replace(Settings().mujoco, joint_offset_sigma_rad=0.0))
    lab = MujocoLab(settings, SimClock())
    arm = settings.load_arm()
    R, o = lab.link1_pose()
    # link1 is base turned by q1 about z, at the base origin (the Panda's panda_link1 body is 0.333 m up)
    assert np.allclose(o, 0.0, atol=1e-12) and np.allclose(R, np.eye(3), atol=1e-9)
    # at the nominal release pose the fingers' slide axis is as near link1's y (the throw plane's
    # normal) as an axis across the flange's z can be: the Panda's exactly; the UR5e's hand points
    # 32 degrees out of the plane (its wrist 2 puts the ball in it), so cos = sqrt(1 - (z . y)^2)
    t = arm.spec.throwing
    q = shape_for(arm).full_q(arm, np.asarray(t.nominal_release), 0.0)
    lab.data.qpos[lab.built.arm_qpos] = q
    mujoco.mj_forward(lab.model, lab.data)
    joint = mujoco.mj_name2id(lab.model, mujoco.mjtObj.mjOBJ_JOINT, "finger_left")
    axis, y = lab.data.xaxis[joint], np.array([0.0, 1.0, 0.0])
    flange_z = arm.frame_placement(q, "flange")[:3, 2]
    best = np.sqrt(1.0 - (flange_z @ y) ** 2)
    assert abs(abs(axis @ y) - best) < 0.01, (axis, best)  # 0.01: the hand's 1 mm origin tolerances
    assert best > {"panda": 0.999, "ur5e": 0.8}[name]
    assert abs(hand_turn(arm)) > 0.5  # neither arm's flange y lies so by itself (the PA-10's does: 0)


@pytest.mark.slow
@pytest.mark.parametrize("name", sorted(SETTINGS))
def test_the_arm_trains_and_throws_in_the_mujoco_world(name):
    world = MujocoWorld(SETTINGS[name], seed=3)
    world.set_calibration(world.true_calibration())
    world.connect()
    pump(world.clock, world.rig, 0.2, step_s=0.001)
    arm = world.arm_model
    area = training_area(arm)
    library = train_in_world(world, np.random.default_rng(0), targets=training_targets(area, nx=3, nz=3))
    assert len(library) == 9 and library.arm == arm.name and world.lab.throws == 9
    planner = ThrowPlanner(arm, library)
    rng = np.random.default_rng(11)
    true_errors, measured_errors = [], []
    for _ in range(4):
        target = np.array([rng.uniform(area.x[0] + 0.05, area.x[1] - 0.05), rng.uniform(area.z[0], area.z[1] - 0.05)])
        return_home(world)  # from home at rest, as the labelled throws started (and `wiithrow throw` does)
        pump(world.clock, world.rig, 0.05, step_s=0.001)
        q = planning_start(world)
        done = execute_throw(world, planner.plan(target, q1=float(q[0]), q_start=q), surface_height=float(target[1]))
        true_errors.append(float(np.hypot(done.landing_link1[0] - target[0], done.landing_link1[1])))
        measured_errors.append(float(np.hypot(done.measured_link1[0] - target[0], done.measured_link1[1])))
    assert np.median(true_errors) <= 0.030 and max(true_errors) <= 0.060, true_errors
    assert np.isfinite(measured_errors).all() and np.median(measured_errors) <= 0.040, measured_errors


def _bare_arm(tmp_path) -> Settings:
    """The UR5e's spec on a copy of its URDF without inertials: an arm with no dynamics."""
    text = re.sub(r"<inertial>.*?</inertial>", "", urdf_path("ur5e").read_text(), flags=re.S)
    path = tmp_path / "bare_arm.urdf"
    path.write_text(text)
    return Settings.from_dict({"arm_spec": spec_of("ur5e").to_dict() | {"name": "bare_arm", "urdf": str(path)}})


def test_an_arm_without_dynamics_is_refused_in_one_line(tmp_path):
    settings = _bare_arm(tmp_path)
    for refuse in (check_arm, build_model):
        with pytest.raises(
            AppError, match=r"needs arm 'bare_arm''s dynamics .* no inertial for link\(s\) shoulder_link"
        ):
            refuse(settings)
    with pytest.raises(AppError) as err:
        check_arm(settings)
    assert "\n" not in str(err.value) and "use the kinematic world" in str(err.value)
    # example-robot-data's UR5 has inertials and efforts: it is built (it has no throwing section)
    check_arm(Settings(arm="ur5"))
    assert build_model(Settings(arm="ur5")).dynamics.torque_limit_nm == (150.0,) * 3 + (28.0,) * 3


@pytest.mark.parametrize("name", ["panda", "ur5e"])
def test_serve_runs_the_arm_over_the_mujoco_drivers(name, tmp_path, capsys):
    """`wiithrow serve --settings examples/mujoco_NAME_settings.json --library L`: the drivers load,
    the arm's MuJoCo world is built and served (L: a 2 x 2 library trained for the arm, in the
    kinematic world for speed; serve refuses another arm's library)."""
    from pathlib import Path

    from wiithrow.app.cli.main import main
    from wiithrow.app.throws.library_file import save_library
    from wiithrow.app.worlds.simulated import SimWorld

    settings = Path(__file__).resolve().parents[2] / "examples" / f"mujoco_{name}_settings.json"
    assert Settings.load(settings).arm == name
    world = SimWorld(Settings(arm=name), seed=1)
    world.set_calibration(world.true_calibration())
    world.connect()
    area = training_area(world.arm_model)
    library = train_in_world(world, np.random.default_rng(0), targets=training_targets(area, nx=2, nz=2))
    path = save_library(tmp_path / "library.json", library)
    argv = ["serve", "--settings", str(settings), "--library", str(path), "--duration", "0.2", "--port", "0"]
    assert main(argv) == 0
    err = capsys.readouterr().err
    assert "Traceback" not in err and err.count(" loaded ") == 3, err


@pytest.mark.slow
@pytest.mark.parametrize("name", ["panda", "ur5e"])
def test_the_session_calibrates_with_the_arm_aligns_and_throws_in_the_mujoco_world(name):
    """What `throw --sim --world mujoco` does, for another arm: the robot-driven calibration (16
    poses, the hand's LED), a 3 x 3 library, then targets off the arm's axis (bearings within
    +-0.4 rad): joint 1 turns the rig on the true link1 until each lies in the throw plane, and
    the validated preview is thrown. Bound: every alignment converges, the median true error
    <= 30 mm (measured, seed 4: Panda 4.7 mm, UR5e 11.7 mm)."""
    from wiithrow.app.session import simulated_session

    session = simulated_session(
        seed=4, world="mujoco", settings=Settings(arm=name), calibration="robot", poses=16, quiet=True
    )
    try:
        area = training_area(session.world.arm_model)
        library = train_in_world(session.world, np.random.default_rng(5), targets=training_targets(area, nx=3, nz=3))
        session.use_library(library)
        rng = np.random.default_rng(11)
        errors = []
        for _ in range(4):
            x, z = rng.uniform(area.x[0] + 0.05, area.x[1] - 0.05), rng.uniform(area.z[0], area.z[1] - 0.05)
            bearing = rng.uniform(-0.4, 0.4)
            session.set_target([x * np.cos(bearing), x * np.sin(bearing), z])
            alignment = session.align()
            assert alignment.converged, alignment.message
            errors.append(session.throw(session.plan_preview().id).true_error_m)
        assert np.median(errors) <= 0.030, errors
    finally:
        session.close()
