"""The release state (ball frame position and Jacobian velocity, in base) and the execution noise
(seeded, with the stated standard deviations)."""

from __future__ import annotations

import numpy as np
import pytest

from wiithrow.robot import JointTrajectory
from wiithrow.throwing.errors import ThrowingError
from wiithrow.throwing.release import ExecutionNoise, noisy_release, release_state


def test_release_state_is_the_ball_frame_state(pa10):
    rng = np.random.default_rng(0)
    for _ in range(10):
        q = rng.uniform(pa10.lower, pa10.upper)
        dq = rng.uniform(-pa10.velocity_limit, pa10.velocity_limit)
        r = release_state(pa10, q, dq, 0.5)
        np.testing.assert_allclose(r.position, pa10.frame_position(q, "ball"), atol=1e-12)
        np.testing.assert_allclose(r.velocity, pa10.frame_velocity(q, dq, "ball"), atol=1e-12)
        # and the velocity is the time derivative of the position along q + dq t
        h = 1e-6
        fd = (pa10.frame_position(q + h * dq, "ball") - pa10.frame_position(q - h * dq, "ball")) / (2 * h)
        np.testing.assert_allclose(r.velocity, fd, atol=1e-7)
        assert r.time == 0.5
    with pytest.raises(ThrowingError):
        release_state(pa10, np.zeros(7), np.zeros(6))


def linear_trajectory(pa10):
    """A trajectory moving every joint at constant speed: q(t) = q0 + v t."""
    t = np.arange(0, 0.501, 0.001)
    v = 0.5 * pa10.velocity_limit
    q0 = np.array([0.1, 0.2, 0.0, 1.0, 0.0, -0.5, 0.0])
    Q = q0 + t[:, None] * v
    return JointTrajectory(t, Q, np.tile(v, (t.size, 1)), np.zeros_like(Q)), q0, v


def test_noise_free_release_is_exact(pa10):
    traj, q0, v = linear_trajectory(pa10)
    r = noisy_release(pa10, traj, 0.25, ExecutionNoise.none(), np.random.default_rng(0))
    np.testing.assert_allclose(r.q, q0 + 0.25 * v, atol=1e-12)
    np.testing.assert_allclose(r.dq, v, atol=1e-12)


def test_noise_has_the_stated_sigmas_and_is_reproducible(pa10):
    traj, q0, v = linear_trajectory(pa10)
    noise = ExecutionNoise(release_jitter_s=0.002, tracking_error_rad=0.0)
    rs = [noisy_release(pa10, traj, 0.25, noise, np.random.default_rng(k)) for k in range(2000)]
    dt = np.array([r.time - 0.25 for r in rs])
    assert abs(dt.std() - 0.002) < 0.0001  # 2000 samples: std of the std ~ 3 %
    assert abs(dt.mean()) < 0.0002
    # the joint state is the trajectory's at the jittered time
    np.testing.assert_allclose(rs[0].q, q0 + rs[0].time * v, atol=1e-12)
    noise = ExecutionNoise(release_jitter_s=0.0, tracking_error_rad=0.001)
    E = np.array([noisy_release(pa10, traj, 0.25, noise, np.random.default_rng(k)).q for k in range(2000)])
    E -= q0 + 0.25 * v
    assert np.all(np.abs(E.std(axis=0) - 0.001) < 0.0001)
    a = noisy_release(pa10, traj, 0.25, ExecutionNoise(), np.random.default_rng(7))
    b = noisy_release(pa10, traj, 0.25, ExecutionNoise(), np.random.default_rng(7))
    np.testing.assert_array_equal(a.position, b.position)
    with pytest.raises(ThrowingError, match="Generator"):
        noisy_release(pa10, traj, 0.25, ExecutionNoise(), None)
    with pytest.raises(ThrowingError):
        ExecutionNoise(release_jitter_s=-1.0)
