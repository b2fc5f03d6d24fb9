"""The feed-forward helper a lab's driver calls (`wiithrow.robot.feedforward`): inverse dynamics of
the arm's model by RNEA, a payload on the flange, the rotors' inertia, and the PD setpoints that
deliver them."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

from wiithrow.robot import RobotError, load_arm
from wiithrow.robot.feedforward import InverseDynamics, Payload, PDFeedForward, pd_setpoints

G = 9.81


@pytest.fixture(scope="module")
def panda():
    return load_arm("panda")


def test_the_torque_of_a_still_arm_is_its_gravity_and_rows_are_each_rnea(panda):
    dynamics = InverseDynamics(panda)
    rng = np.random.default_rng(1)
    q = np.clip(panda.home + rng.uniform(-0.4, 0.4, (5, panda.nq)), panda.lower, panda.upper)
    v, a = rng.uniform(-1, 1, (2, 5, panda.nq))
    still = dynamics.torque(q[0], np.zeros(panda.nq), np.zeros(panda.nq))
    np.testing.assert_allclose(still, dynamics.gravity(q[0]), atol=1e-9)
    assert np.abs(still).max() > 5.0  # the shoulder holds the arm up: tens of N m, not nothing
    rows = dynamics.torque(q, v, a)
    assert rows.shape == (5, panda.nq)
    for i in range(5):
        np.testing.assert_allclose(
            rows[i], pin.rnea(panda.model, panda.model.createData(), q[i], v[i], a[i]), atol=1e-9
        )


def test_a_payload_adds_its_weight_through_the_jacobian_and_rotors_add_their_inertia(panda):
    q = panda.home
    offset = panda.frame_offsets["ball"]
    loaded = InverseDynamics(panda, payload=Payload(0.6, offset))
    # holding a point mass m at the `ball` frame takes J^T (0, 0, m g) more
    J = panda.frame_jacobian(q, "ball")[:3]
    np.testing.assert_allclose(
        loaded.gravity(q) - InverseDynamics(panda).gravity(q), J.T @ np.array([0, 0, 0.6 * G]), atol=1e-6
    )
    rotor = np.full(panda.nq, 0.1)
    a = np.linspace(1.0, 7.0, panda.nq)
    zero = np.zeros(panda.nq)
    with_rotor = InverseDynamics(panda, rotor_inertia=rotor).torque(q, zero, a)
    np.testing.assert_allclose(with_rotor - InverseDynamics(panda).torque(q, zero, a), rotor * a, atol=1e-9)
    assert np.allclose(
        panda.frame_position(q, "ball"), load_arm("panda").frame_position(q, "ball")
    )  # the arm's own model untouched


def test_pd_setpoints_deliver_the_torque_and_cancel_the_damping():
    kp, kd = np.array([4500.0, 2000.0]), np.array([414.0, 184.0])
    q_ref, v_ref, tau = np.array([0.1, -0.2]), np.array([2.0, -1.0]), np.array([30.0, -3.0])
    q_set = pd_setpoints(q_ref, v_ref, tau, kp, kd)
    # the servo at perfect tracking: K_p (q_set - q_ref) - K_d v_ref = tau
    np.testing.assert_allclose(kp * (q_set - q_ref) - kd * v_ref, tau, atol=1e-12)
    np.testing.assert_allclose(pd_setpoints(q_ref, v_ref, None, kp, np.zeros(2)), q_ref)
    with pytest.raises(RobotError, match="K_p must be positive"):
        pd_setpoints(q_ref, v_ref, tau, np.array([4500.0, 0.0]), kd)


def test_the_feedforwards_terms_are_checked(panda):
    kp, kd = np.full(panda.nq, 1000.0), np.full(panda.nq, 90.0)
    with pytest.raises(RobotError, match="unknown feed-forward term"):
        PDFeedForward(kp, kd, ("velocity", "friction"))
    with pytest.raises(RobotError, match="needs the arm's InverseDynamics"):
        PDFeedForward(kp, kd, ("inverse_dynamics",))
    with pytest.raises(RobotError, match="mass must be 0-100 kg"):
        Payload(-1.0)
    velocity_only = PDFeedForward(kp, kd, ("velocity",))
    q, v = panda.home, np.full(panda.nq, 0.5)
    np.testing.assert_allclose(velocity_only.setpoints(q, v, np.zeros(panda.nq)), q + 0.09 * v)
    assert velocity_only.terms == ("velocity",)
