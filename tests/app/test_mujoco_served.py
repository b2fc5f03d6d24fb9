"""The MuJoCo world served as hardware: `HardwareWorld` loads the arm, the hand and the remotes
from `examples/mujoco_settings.json` (what `wiithrow serve --settings` does) and a throw runs end to
end on the system clock: track, preview, throw, then the operator's *Measure landing*."""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np
import pytest

from wiithrow.app.session import Session
from wiithrow.app.settings import Settings
from wiithrow.app.worlds.hardware import HardwareWorld
from wiithrow.app.worlds.mujoco.devices import MujocoArm, MujocoGripper
from wiithrow.robot.gripper import Gripper

SETTINGS = Path(__file__).resolve().parents[2] / "examples" / "mujoco_settings.json"

pytestmark = pytest.mark.slow


def test_serving_the_mujoco_devices_throws_and_measures_the_landing_as_on_hardware():
    world = HardwareWorld(Settings.load(SETTINGS))
    assert isinstance(world.arm, MujocoArm) and isinstance(world.gripper, MujocoGripper)
    assert isinstance(world.gripper, Gripper) and not world.simulated
    assert world.arm.lab is world.gripper.lab, "one physical world behind every device"
    session = Session(world, rng=np.random.default_rng(0))
    try:
        session.use_calibration(world.true_calibration())
        session.start()
        alignment = session.align()
        assert alignment.converged, alignment.message
        preview = session.plan_preview()
        record = session.throw(preview.id)
        # hardware does not know where the ball came down: the operator marks it
        assert np.isnan(record.landing_xz).all() and np.isnan(record.execution.landing_base).all()
        assert "Measure landing" in session.last_message
        lab = world.gripper.lab
        time.sleep(1.5)  # the ball comes down, the operator walks over (the rig loop keeps reading)
        assert lab.events.marker is not None, "the simulated operator put the marker down"
        measured = session.measure_landing()
        assert np.isfinite(measured.landing_xz).all()
        # the rig's measurement of the operator's marker, near where the ball really came down
        truth = world.base_to_link1(lab.events.touchdown, np.r_[preview.q1, np.zeros(6)])[0]
        assert np.linalg.norm(measured.landing_xz - truth[[0, 2]]) < 0.03
        # (how close it lands is measured on a simulated clock, test_mujoco_throwing.py: on the system
        # clock a busy machine makes the release command late)
        assert measured.error_m < 0.3, measured.error_m
        assert not lab.lit["landing"], "the operator took the marker away after the measurement"
    finally:
        session.close()


def test_settings_naming_an_arm_without_mujoco_dynamics_are_one_line_not_a_traceback(tmp_path):
    """`serve --settings` with arm ur5 over the MuJoCo drivers was `ValueError: shape mismatch ... (6,) ... (7,)`;
    the world is now built from any arm's URDF, and one whose URDF has no inertials is refused in a line."""
    import json
    import re
    import subprocess
    import sys

    from wiithrow.robot import spec_of, urdf_path

    bare = tmp_path / "bare_arm.urdf"
    bare.write_text(re.sub(r"<inertial>.*?</inertial>", "", urdf_path("ur5e").read_text(), flags=re.S))
    document = json.loads(SETTINGS.read_text())
    document["settings"]["arm_spec"] = spec_of("ur5e").to_dict() | {"name": "bare_arm", "urdf": str(bare)}
    settings = tmp_path / "bare.json"
    settings.write_text(json.dumps(document))
    argv = [str(Path(sys.executable).with_name("wiithrow")), "serve", "--settings", str(settings), "--port", "0"]
    result = subprocess.run(argv, capture_output=True, text=True, timeout=120)
    assert result.returncode == 2, result.stderr
    assert "Traceback" not in result.stderr, result.stderr
    last = result.stderr.strip().splitlines()[-1]  # after the lines naming the drivers loaded
    assert last.startswith("wiithrow serve: the MuJoCo world needs arm 'bare_arm''s dynamics and its URDF"), last
    assert last.endswith(
        "has no inertial for link(s) shoulder_link, upper_arm_link, forearm_link, wrist_1_link, "
        "wrist_2_link, wrist_3_link: add them to the URDF, or use the kinematic world"
    ), last
