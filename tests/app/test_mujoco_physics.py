"""The MuJoCo world's physics against what docs/simulation.md says it is: the ball under MuJoCo's
fluid model against an independent integration of the same forces, the grip through the fastest
throw's speed-up and its release after the hand's latency, the servo's step response, and the
manufacturing tolerances that make the nominal kinematics slightly wrong."""

from __future__ import annotations

import math

import mujoco
import numpy as np

from wiithrow.app.settings import MujocoSettings, Settings
from wiithrow.app.worlds.mujoco import params
from wiithrow.app.worlds.mujoco.devices import MujocoArm, MujocoGripper
from wiithrow.app.worlds.mujoco.lab import MujocoLab
from wiithrow.clock import SimClock
from wiithrow.robot import load_arm
from wiithrow.throwing import TRAINING_AREA, plan_throw, solve_throw

G = 9.81


def lab(settings: Settings | None = None) -> tuple[MujocoLab, SimClock]:
    clock = SimClock()
    return MujocoLab(settings or Settings(), clock), clock


def set_ball(lab: MujocoLab, position, velocity, spin_world=(0.0, 0.0, 0.0)) -> None:
    """Put the ball somewhere with a velocity and an angular velocity (world frame), upright."""
    b, d = lab.built, lab.data
    d.qpos[b.ball_qpos : b.ball_qpos + 7] = [*position, 1.0, 0.0, 0.0, 0.0]
    d.qvel[b.ball_dof : b.ball_dof + 3] = velocity
    d.qvel[b.ball_dof + 3 : b.ball_dof + 6] = spin_world  # body frame = world frame while upright
    mujoco.mj_forward(lab.model, d)


def reference_flight(settings: Settings, v0, w0, duration: float, h: float = 1e-4):
    """RK4 of the ellipsoid fluid model for a sphere (MuJoCo's docs, 'Ellipsoid model'), written
    out here independently: quadratic drag rho C_blunt pi r^2 |v| v, Stokes drag 6 pi r beta v, lift
    rho V (C_M - 1/2) w x v (Magnus minus the added-mass term), angular drag
    (rho C_ang 8/15 pi r^5 |w| + beta pi (2r)^3) w, gravity. Returns times and (position offset, velocity)."""
    ball = settings.ball
    r, m, rho = ball.radius_m, ball.mass_kg, ball.air_density
    beta = params.AIR_KINEMATIC_VISCOSITY
    c_blunt, c_ang, c_m = 0.5 * ball.drag_coefficient, 1.5, 1.0
    volume = 4.0 / 3.0 * math.pi * r**3
    inertia = params.SHELL_INERTIA_FACTOR * m * r * r
    i_d = 8.0 / 15.0 * math.pi * r**5

    def f(state):
        v, w = state[3:6], state[6:9]
        speed = np.linalg.norm(v)
        force = -(beta * 6 * math.pi * r + rho * speed * c_blunt * math.pi * r * r) * v
        force = force + rho * volume * (c_m - 0.5) * np.cross(w, v) + np.array([0.0, 0.0, -G * m])
        torque = -(rho * c_ang * i_d * np.linalg.norm(w) + beta * math.pi * (2 * r) ** 3) * w
        return np.concatenate([v, force / m, torque / inertia])

    y = np.concatenate([np.zeros(3), v0, w0]).astype(float)
    times, states = [0.0], [y.copy()]
    for k in range(round(duration / h)):
        k1 = f(y)
        k2 = f(y + 0.5 * h * k1)
        k3 = f(y + 0.5 * h * k2)
        k4 = f(y + h * k3)
        y = y + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
        times.append((k + 1) * h)
        states.append(y.copy())
    return np.array(times), np.array(states)


def run_ball(lab: MujocoLab, clock: SimClock, duration: float):
    b, d = lab.built, lab.data
    start = d.qpos[b.ball_qpos : b.ball_qpos + 3].copy()
    out = []
    for _ in range(round(duration / lab.h)):
        clock.advance(lab.h)
        lab.advance()
        out.append((lab.t, *(d.qpos[b.ball_qpos : b.ball_qpos + 3] - start), *d.qvel[b.ball_dof : b.ball_dof + 3]))
    return np.array(out)


def test_the_dropped_ball_falls_as_the_fluid_model_says():
    world, clock = lab()
    set_ball(world, (1.5, 1.5, 4.0), (0.0, 0.0, 0.0))
    sim = run_ball(world, clock, 0.8)
    times, ref = reference_flight(world.settings, (0.0, 0.0, 0.0), (0.0, 0.0, 0.0), 0.8)
    vz_ref = np.interp(sim[:, 0], times, ref[:, 5])
    # the velocity: semi-implicit Euler keeps it exact for constant forces; drag is far from stiff
    assert np.max(np.abs(sim[:, 6] - vz_ref)) < 2e-3
    # drag is really there: 0.8 s of free fall would reach 7.85 m/s
    assert G * 0.8 - abs(sim[-1, 6]) > 0.1
    # the position: semi-implicit Euler's offset of g t h / 2 (3.9 mm at 0.8 s) on top of the exact fall
    z_ref = np.interp(sim[:, 0], times, ref[:, 2])
    euler_offset = -G * sim[:, 0] * world.h / 2
    assert np.max(np.abs(sim[:, 3] - z_ref - euler_offset)) < 5e-4


def test_a_spinning_ball_is_lifted_sideways_as_the_fluid_model_says():
    world, clock = lab()
    v0, w0 = np.array([5.0, 0.0, 0.0]), np.array([0.0, 0.0, 30.0])  # topspin about z: w x v along +y
    set_ball(world, (-1.0, -1.5, 3.0), v0, w0)
    sim = run_ball(world, clock, 0.5)
    times, ref = reference_flight(world.settings, v0, w0, 0.5)
    y_ref = np.interp(sim[:, 0], times, ref[:, 1])
    assert sim[-1, 2] > 0.015, "the lift from spin moves the ball sideways"
    assert np.max(np.abs(sim[:, 2] - y_ref)) < 1e-3


def fastest_throw(model):
    """The trained area's far-high corner: the library's fastest throw (84 % of the E1/W1 limits)."""
    corner = np.array([TRAINING_AREA.x[1], TRAINING_AREA.z[1]])
    return plan_throw(model, solve_throw(model, corner), float(corner[1]), q1=0.0)


def test_the_grip_holds_through_the_fastest_speed_up_and_lets_go_after_the_latency():
    settings = Settings()
    world, clock = lab(settings)
    model = load_arm("pa10")
    arm, hand = MujocoArm(model, clock, world), MujocoGripper(world)
    plan = fastest_throw(model)
    arm.command_position(plan.trajectory.positions[0])
    assert arm.wait_until_idle(10.0)
    hand.close()
    clock.advance(0.1)
    assert hand.state().holding and hand.state().command == "closed"
    seat = world.built.sites["ball_seat"]

    def offset_in_hand():
        d = world.data
        world.advance()
        rotation = d.site_xmat[seat].reshape(3, 3)
        return rotation.T @ (world.ball_position_now() - d.site_xpos[seat])

    before = offset_in_hand()
    start = clock.now()
    arm.command_trajectory(plan.trajectory)
    creep = 0.0
    while clock.now() < start + plan.release_time - 1e-9:
        clock.advance(0.001)
        creep = max(creep, float(np.linalg.norm(offset_in_hand() - before)))
    assert world.events.released_at is None and hand.state().holding
    assert creep < 0.005, f"the ball crept {1e3 * creep:.1f} mm in the hand during the speed-up"
    hand.open()
    t_open = clock.now()
    while world.events.released_at is None and clock.now() < t_open + 0.1:
        clock.advance(0.001)
        world.advance()
    delay = world.gripper_delays[-1]  # this command's latency + jitter, as drawn
    released = world.events.released_at
    assert released is not None
    assert settings.mujoco.release_latency_s - 4 * settings.mujoco.release_jitter_s < delay
    # the ball leaves as the pads start to move: within a few servo periods of the drawn delay
    assert 0.0 <= released - (t_open + delay) < 0.006, released - t_open
    assert np.linalg.norm(world.events.release_velocity) > 2.5, "it leaves at the throw's speed"


def test_a_velocity_step_is_followed_with_the_documented_lag():
    settings = Settings()
    world, clock = lab(settings)
    step = np.zeros(7)
    step[3] = 0.5  # E1, rad/s
    world.attach_host(lambda t, q, dq: step)
    speeds = []
    for _ in range(60):
        clock.advance(0.001)
        _, _, dq = world.read_arm()
        speeds.append(dq[3])
    speeds = np.array(speeds)
    tau = 1.0 / (2 * math.pi * settings.mujoco.velocity_bandwidth_hz)  # docs: about 1 / w_v
    t63 = (np.argmax(speeds >= 0.63 * 0.5) + 1) * 0.001
    assert 0.5 * tau <= t63 <= 2.5 * tau, (t63, tau)
    assert abs(speeds[-1] - 0.5) < 0.02 and speeds.max() < 0.5 * 1.3  # settles, overshoots little


def test_the_worlds_arm_is_not_the_nominal_one_by_the_stated_tolerances():
    model = load_arm("pa10")
    q = np.array([0.3, 0.5, 0.1, 1.0, -0.2, 0.4, 0.3])
    for sigma_l, sigma_q, low, high in ((0.001, 0.002, 0.5e-3, 15e-3), (0.0, 0.0, 0.0, 1e-9)):
        settings = Settings().replace(
            mujoco=MujocoSettings(link_length_sigma_m=sigma_l, joint_offset_sigma_rad=sigma_q)
        )
        world, _ = lab(settings)
        d = world.data
        d.qpos[world.built.joint_qpos] = q
        mujoco.mj_kinematics(world.model, d)
        true_led = d.site_xpos[world.built.sites["marker_led"]]
        error = np.linalg.norm(true_led - model.frame_position(q, "marker"))
        assert low <= error <= high, (sigma_l, error)
    assert np.std(world.built.tolerances["joint_offset_rad"]) == 0.0


def test_the_ball_bounces_on_the_floor():
    world, clock = lab()
    r = world.settings.ball.radius_m
    set_ball(world, (1.5, 1.5, 1.0 + r), (0.0, 0.0, 0.0))
    sim = run_ball(world, clock, 1.2)
    z = sim[:, 3] + 1.0 + r
    falling = np.argmax(sim[:, 6] > 0)  # the first bounce
    apex = z[falling:].max() - r
    # e = 0.75 from a 1 m drop comes back to about e^2 = 0.56 m (less the air's drag)
    assert 0.45 < apex < 0.6, apex


def test_after_a_training_landing_the_table_stands_under_the_target_again():
    """A training throw's surface is the one table, moved under the training target; once its landing
    is measured the operator puts it back under the target: a throw at the target after a training
    came down on the table left at the training's last target (z 0.40 m for a target at 0.20 m)."""
    world, _clock = lab()
    b = world.built
    target = np.array([1.3, 0.0, 0.2])
    world.place_target(target)
    under_target = world.data.mocap_pos[b.table_mocap].copy()
    assert np.allclose(under_target, [1.3, 0.0, 0.2 - b.table_half[2]])
    world.place_table([1.2, 0.0, 0.4])  # a training target's surface
    world.place_landing_marker(np.array([1.21, 0.0, 0.4]))
    assert np.allclose(world.data.mocap_pos[b.table_mocap], [1.2, 0.0, 0.4 - b.table_half[2]])
    world.landing_measured()
    assert np.allclose(world.data.mocap_pos[b.table_mocap], under_target)
    world.place_target(np.array([1.4, 0.0, b.floor_z]))  # a target on the floor: no table
    world.place_table([1.2, 0.0, 0.4])
    world.landing_measured()
    assert world.data.mocap_pos[b.table_mocap][2] < b.floor_z, "a target on the floor has no table under it"
