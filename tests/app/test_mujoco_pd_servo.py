"""Arms whose servo takes position setpoints, a joint PD without gravity compensation, as vendors'
and labs' MuJoCo models define them: raw setpoints lag a moving reference by K_d / K_p and sag by
g / K_p; the shipped driver's feed-forward (`mujoco.feedforward`, `wiithrow.robot.feedforward`)
removes the lag (the velocity term) and the sag and the inertial lag (the inverse dynamics). The
figures are `wiithrow bench following`'s (`app/cli/bench/following.py`)."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import mujoco
import numpy as np
import pytest

from wiithrow.app.cli.bench.following import follow_throw
from wiithrow.app.errors import AppError
from wiithrow.app.settings import Settings
from wiithrow.app.worlds.mujoco.arm_servo import servo_of
from wiithrow.app.worlds.mujoco.devices import MujocoArm, MujocoPositionArm
from wiithrow.app.worlds.mujoco.world import MujocoWorld

FOREIGN = Path(__file__).resolve().parents[1] / "data" / "foreign_worlds"


def with_feedforward(settings: Settings, choice: str) -> Settings:
    return settings.replace(mujoco=dataclasses.replace(settings.mujoco, feedforward=choice))


@pytest.fixture(scope="module")
def pd_panda() -> Settings:
    """The project's Panda on a PD servo: K_d / K_p = 0.09 s (`mujoco.pd_lag_s`)."""
    base = Settings(arm="panda")
    return base.replace(mujoco=dataclasses.replace(base.mujoco, arm_servo="pd_position"))


def test_raw_setpoints_lag_by_the_servos_damping_and_the_feedforward_removes_it(pd_panda):
    raw = follow_throw(with_feedforward(pd_panda, "none"))
    velocity = follow_throw(with_feedforward(pd_panda, "velocity"))
    dynamics = follow_throw(with_feedforward(pd_panda, "inverse_dynamics"))
    print(f"raw {raw}\nvelocity term {velocity}\ninverse dynamics {dynamics}")
    lag = pd_panda.mujoco.pd_lag_s
    assert abs(raw["lag_s"] - lag) < 0.1 * lag  # measured 90.2 ms for K_d / K_p = 90 ms
    assert raw["rms_rad"] > 0.1  # a throw's joints 0.1-0.2 rad behind
    assert abs(velocity["lag_s"]) < 0.005  # measured 2.4 ms: what is left is inertia and gravity
    assert abs(dynamics["lag_s"]) < 0.002 and dynamics["rms_rad"] < 0.003  # measured -0.3 ms, 1.4 mrad
    # at rest: the sag g / K_p (the shoulder's 8 mrad) without the torque term, none with it
    assert raw["sag_rad"] > 0.005 and velocity["sag_rad"] == pytest.approx(raw["sag_rad"], rel=0.01)
    assert dynamics["sag_rad"] < 0.001


def test_the_labs_pd_panda_lags_92_ms_raw_and_follows_with_its_inverse_dynamics():
    lab = Settings.load(FOREIGN / "panda_pd" / "settings.json")
    raw = follow_throw(with_feedforward(lab, "none"))
    dynamics = follow_throw(with_feedforward(lab, "inverse_dynamics"))
    print(f"raw {raw}\ninverse dynamics {dynamics}")
    assert 0.08 < raw["lag_s"] < 0.1  # its K_d / K_p, 0.092 s: the 92 ms the lab measured
    # the feed-forward is the planner's model (the URDF's masses), not the lab's: still within 2 ms
    assert abs(dynamics["lag_s"]) < 0.002 and dynamics["rms_rad"] < 0.003 and dynamics["sag_rad"] < 0.002


def test_the_shipped_driver_is_the_host_its_servo_takes(pd_panda):
    world = MujocoWorld(with_feedforward(pd_panda, "inverse_dynamics"))
    assert isinstance(world.arm, MujocoPositionArm)
    assert world.arm.feedforward_terms == ("velocity", "inverse_dynamics")
    assert world.lab.built.servo is not None and world.lab.built.servo.kind == "position"
    # K_p = J w^2 at home (w = 2 pi 10 Hz), K_d = K_p 0.09 s
    servo = world.lab.built.servo
    np.testing.assert_allclose(servo.kd, 0.09 * servo.kp)
    assert 1000 < servo.kp[1] < 10000
    velocity = MujocoWorld(Settings.load(FOREIGN / "ur5e_velocity" / "settings.json"))
    assert isinstance(velocity.arm, MujocoArm) and velocity.lab.built.servo.kind == "velocity"  # type: ignore[union-attr]
    assert isinstance(MujocoWorld(Settings(arm="panda")).arm, MujocoArm)  # the project's amplifier: unchanged


def test_an_actuator_that_is_no_servo_the_drivers_know_is_one_line():
    spec = mujoco.MjSpec.from_string(
        """<mujoco><worldbody><body><joint name="j"/><geom size="0.1"/></body></worldbody>
        <actuator><general name="odd" joint="j" gainprm="100" biastype="affine" biasprm="0 -50 -10"/>
        <position name="pd" joint="j" kp="100"/><velocity name="v" joint="j" kv="10"/></actuator></mujoco>"""
    )
    model = spec.compile()
    with pytest.raises(AppError, match="actuator 'odd' is none of a motor"):
        servo_of(model, [0], [0], "the lab's MJCF")
    assert servo_of(model, [1], [0], "x").kind == "position"
    with pytest.raises(AppError, match="actuator 'v' is a velocity servo, the arm's first a position servo"):
        servo_of(model, [1, 2], [0, 0], "the lab's MJCF")
