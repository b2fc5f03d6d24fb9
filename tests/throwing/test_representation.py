"""The throw representation: the reference's boundary states and consistency, its closed-form
peaks, feasibility by construction, the parameter checks and round trips."""

from __future__ import annotations

import numpy as np
import pytest

from wiithrow.robot import load_arm
from wiithrow.throwing.errors import InfeasibleThrowError, LibraryFormatError, ThrowingError
from wiithrow.throwing.representation import ThrowParameters, ThrowShape

SHAPE = ThrowShape()
VMAX = np.array([1.0, 2.0, 6.2832])  # S2, E1, W1


def random_params(rng, margin=0.95):
    return ThrowParameters(rng.uniform([0.3, -0.8, -0.8], [1.0, 0.0, 0.2]), rng.uniform(-1, 1, 3) * margin * VMAX)


def test_reference_boundary_states():
    p = ThrowParameters([0.7, -0.4, -0.3], [0.5, 1.2, 4.0])
    T = SHAPE.acceleration_time
    q, dq, ddq = SHAPE.reference(p, [0.0, T])
    np.testing.assert_allclose(q[0], SHAPE.windup(p), atol=1e-15)
    np.testing.assert_allclose(q[0], p.q_release - p.dq_release * T / 2, atol=1e-15)
    np.testing.assert_allclose(dq[0], 0.0, atol=1e-15)
    np.testing.assert_allclose(ddq[0], 0.0, atol=1e-15)
    np.testing.assert_allclose(q[1], p.q_release, atol=1e-14)
    np.testing.assert_allclose(dq[1], p.dq_release, atol=1e-14)
    np.testing.assert_allclose(ddq[1], 0.0, atol=1e-14)
    times, Q, V, _A = SHAPE.knots(p)
    assert times.size == SHAPE.n_knots + 1 == 9
    np.testing.assert_array_equal(Q[-1], p.q_release)
    np.testing.assert_array_equal(V[-1], p.dq_release)


def test_reference_derivatives_are_consistent():
    p = ThrowParameters([0.7, -0.4, -0.3], [0.5, 1.2, 4.0])
    t = np.linspace(0.01, 0.31, 50)
    h = 1e-6
    q_p, dq_p, _ = SHAPE.reference(p, t + h)
    q_m, dq_m, _ = SHAPE.reference(p, t - h)
    _, dq, ddq = SHAPE.reference(p, t)
    np.testing.assert_allclose((q_p - q_m) / (2 * h), dq, atol=1e-7)
    np.testing.assert_allclose((dq_p - dq_m) / (2 * h), ddq, atol=1e-5)


def test_closed_form_peaks_and_feasibility_by_construction(pa10):
    """Any release velocity within 95 % of the limits gives a reference within the acceleration and
    jerk limits (sampled densely, jerk by finite differences)."""
    rng = np.random.default_rng(0)
    mov = [1, 3, 5]
    t = np.linspace(0, SHAPE.acceleration_time, 3201)
    worst_a = worst_j = 0.0
    for _ in range(200):
        p = random_params(rng)
        _, _, ddq = SHAPE.reference(p, t)
        jerk = np.diff(ddq, axis=0) / np.diff(t)[:, None]
        a_peak, j_peak = SHAPE.peaks(p)
        np.testing.assert_allclose(np.abs(ddq).max(axis=0), a_peak, rtol=1e-5)
        np.testing.assert_allclose(np.abs(jerk).max(axis=0), j_peak, rtol=1e-3)
        worst_a = max(worst_a, np.max(np.abs(ddq) / pa10.acceleration_limit[mov]))
        worst_j = max(worst_j, np.max(np.abs(jerk) / pa10.jerk_limit[mov]))
        SHAPE.check(pa10, p)
    assert worst_a < 0.84 and worst_j < 0.63  # 16 % and 37 % to spare, as the docstring says


def test_check_refuses_what_is_not_executable(pa10):
    ok = ThrowParameters([0.7, -0.4, -0.3], 0.95 * VMAX)
    SHAPE.check(pa10, ok)
    with pytest.raises(InfeasibleThrowError, match="W1.*95%"):
        SHAPE.check(pa10, ThrowParameters([0.7, -0.4, -0.3], [0.5, 1.0, 0.96 * 6.2832]))
    with pytest.raises(InfeasibleThrowError, match="acceleration_time"):
        ThrowShape(acceleration_time=0.12, knot_interval=0.04).check(pa10, ok)
    with pytest.raises(InfeasibleThrowError, match="wind-up.*W1"):
        SHAPE.check(pa10, ThrowParameters([0.7, -0.4, -2.5], [0.5, 1.0, 5.0]))  # wind-up W1 = -2.5 - 0.8
    with pytest.raises(InfeasibleThrowError, match="release.*S2"):
        SHAPE.check(pa10, ThrowParameters([1.6, -0.4, -0.3], [0.9, 0.0, 0.0]))
    with pytest.raises(ThrowingError, match="multiple"):
        ThrowShape(acceleration_time=0.33, knot_interval=0.04)
    with pytest.raises(ThrowingError, match="both"):
        ThrowShape(moving_joints=("S2", "E1", "W1"), held_joints=(("S2", 0.0),))


def test_joint_layout_and_full_vectors(pa10):
    mov, held, _hv = SHAPE.joint_layout(pa10)
    assert [pa10.joint_names[i] for i in mov] == ["S2", "E1", "W1"]
    assert [pa10.joint_names[i] for i in held] == ["S3", "E2", "W2"]
    q = SHAPE.full_q(pa10, [[0.1, 0.2, 0.3], [0.4, 0.5, 0.6]], 0.7)
    np.testing.assert_array_equal(q, [[0.7, 0.1, 0, 0.2, 0, 0.3, 0], [0.7, 0.4, 0, 0.5, 0, 0.6, 0]])
    np.testing.assert_array_equal(SHAPE.full_dq(pa10, [1, 2, 3]), [0, 1, 0, 2, 0, 3, 0])
    with pytest.raises(ThrowingError, match="lacks"):
        ThrowShape(moving_joints=("S2", "elbow", "W1")).joint_layout(pa10)
    ur5 = load_arm("ur5")
    with pytest.raises(ThrowingError):
        SHAPE.joint_layout(ur5)


def test_round_trips():
    p = ThrowParameters([0.7, -0.4, -0.3], [0.5, 1.2, 4.0])
    assert ThrowParameters.from_vector(p.vector) == p
    assert p != ThrowParameters([0.7, -0.4, -0.3], [0.5, 1.2, 4.1])
    q = ThrowParameters.from_dict(p.to_dict())
    np.testing.assert_array_equal(q.vector, p.vector)
    assert ThrowShape.from_dict(SHAPE.to_dict()) == SHAPE
    with pytest.raises(LibraryFormatError):
        ThrowShape.from_dict({"moving_joints": ["S2"]})
    with pytest.raises(LibraryFormatError):
        ThrowParameters.from_dict({"q": [1]})
    with pytest.raises(ThrowingError):
        ThrowParameters([1.0, 2.0], [1.0])
    with pytest.raises(ThrowingError):
        ThrowParameters.from_vector([1.0, 2.0, 3.0])
