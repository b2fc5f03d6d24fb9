"""`wiithrow.app.drivercheck.motions.time_scaled`: the slowed trajectory a driver check follows."""

from __future__ import annotations

import numpy as np

from wiithrow.app.drivercheck.motions import time_scaled
from wiithrow.robot import JointTrajectory


def _min_jerk(duration_s: float, dt: float = 0.001) -> JointTrajectory:
    """A rest-to-rest quintic on two joints, sampled every `dt` and at its end: at rest at both
    ends, its jerk there is not zero (so a sample just before the end is not at rest)."""
    t = np.append(np.arange(0.0, duration_s - 0.5 * dt, dt), duration_s)
    tau = (t / duration_s)[:, None]
    delta = np.array([[0.8, -0.5]])
    q = delta * (10 * tau**3 - 15 * tau**4 + 6 * tau**5)
    dq = delta * (30 * tau**2 - 60 * tau**3 + 30 * tau**4) / duration_s
    ddq = delta * (60 * tau - 180 * tau**2 + 120 * tau**3) / duration_s**2
    return JointTrajectory(t, q, dq, ddq)


def test_a_slowed_trajectory_ends_at_its_end_at_rest_even_just_past_a_grid_point():
    """Slowed 2 times, a move of 1.00005 s ends 0.1 ms after the 1 kHz grid's point at 2.000 s:
    the resampled trajectory still ends at 2.0001 s, at rest (it ended at 2.000 s, 0.01 rad/s^2
    from rest, and the validator refused a driver check's throw so, at random by the start pose)."""
    traj = _min_jerk(1.00005)
    slowed = time_scaled(traj, 2.0)
    assert slowed.times[-1] == 2.0 * traj.times[-1]
    np.testing.assert_allclose(slowed.positions[-1], traj.positions[-1], atol=1e-12)
    assert np.abs(slowed.velocities[-1]).max() < 1e-12 and np.abs(slowed.accelerations[-1]).max() < 1e-12
    steps = np.diff(slowed.times)
    assert steps.min() > 0.2e-3 and steps.max() < 1.2e-3 + 1e-12  # a 1 kHz grid still (its last step up to 1.2 ms)


def test_a_slowed_trajectory_is_the_original_at_the_scaled_times():
    traj = _min_jerk(0.5)
    slowed = time_scaled(traj, 2.0)
    q, dq, ddq = traj.sample(slowed.times / 2.0)
    np.testing.assert_allclose(slowed.positions, q, atol=1e-6)
    np.testing.assert_allclose(slowed.velocities, dq / 2.0, atol=1e-5)
    np.testing.assert_allclose(slowed.accelerations, ddq / 4.0, atol=1e-3)
