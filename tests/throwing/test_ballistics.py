"""Ballistics: the drag integrator against the closed form, its convergence order, the size of the
drag effect, 3D/planar consistency, and the inverse helpers."""

from __future__ import annotations

import math

import numpy as np
import pytest

from wiithrow.throwing.ballistics import (
    Ball,
    flight_path,
    fly,
    fly_planar,
    landing_no_drag,
    min_speed_to_hit,
    speed_to_hit,
)
from wiithrow.throwing.errors import NoLandingError, ThrowingError, UnreachableTargetError


def random_releases(rng, n):
    """Release states like the PA-10's: height 1.0-1.5 m, speed 1.5-4 m/s, -30..60 deg."""
    for _ in range(n):
        speed, ang = rng.uniform(1.5, 4.0), np.radians(rng.uniform(-30, 60))
        yield rng.uniform(1.0, 1.5), speed * math.cos(ang), speed * math.sin(ang), rng.uniform(0.0, 0.4)


def test_integrator_matches_closed_form_without_drag():
    """Cd = 0 through the RK4 path (Newton landing on the crossing) vs the closed form: < 1e-6 m."""
    rng = np.random.default_rng(0)
    vacuum = Ball().without_drag()
    # force the integrator: a drag constant of zero but drag=True goes to the closed form, so use a
    # negligible but non-zero drag coefficient and compare against the closed form
    tiny = Ball(drag_coefficient=1e-12)
    worst = 0.0
    for z0, vx, vz, zl in random_releases(rng, 200):
        x_cf, t_cf, _, vz_cf = fly_planar(0.0, z0, vx, vz, zl, vacuum)
        x_rk, t_rk, _, vz_rk = fly_planar(0.0, z0, vx, vz, zl, tiny, drag=True)
        worst = max(worst, abs(x_rk - x_cf))
        assert t_rk == pytest.approx(t_cf, abs=1e-9)
        assert vz_rk == pytest.approx(vz_cf, abs=1e-8)
    assert worst < 1e-6, worst


def test_closed_form_is_the_textbook_formula():
    # from z0 = 1 m at (3, 0) m/s down to z = 0: t = sqrt(2 / g), x = 3 t
    x, t, _vx, vz = fly_planar(0.0, 1.0, 3.0, 0.0, 0.0, Ball(), drag=False)
    assert t == pytest.approx(math.sqrt(2 / 9.81), rel=1e-12)
    assert x == pytest.approx(3 * t, rel=1e-12)
    assert vz == pytest.approx(-9.81 * t, rel=1e-12)


def test_drag_integrator_converges_with_fourth_order():
    ball = Ball()
    ref = fly_planar(0.0, 1.3, 3.0, 0.5, 0.0, ball, step=1e-4)
    errs = {h: abs(fly_planar(0.0, 1.3, 3.0, 0.5, 0.0, ball, step=h)[0] - ref[0]) for h in (0.04, 0.02, 0.01)}
    # halving the step divides the error by ~2^4 = 16
    assert 10 < errs[0.04] / errs[0.02] < 25
    assert 10 < errs[0.02] / errs[0.01] < 25
    assert errs[0.02] < 1e-8  # the default step (20 ms) is far below any measurable error
    assert errs[0.04] < 1e-6


def test_drag_shortens_the_range_by_a_few_cm_at_3_m_per_s():
    ball = Ball()
    x_vac = fly_planar(0.0, 1.3, 3.0, 0.5, 0.0, ball, drag=False)[0]
    x_air = fly_planar(0.0, 1.3, 3.0, 0.5, 0.0, ball)[0]
    loss = x_vac - x_air
    assert 0.01 < loss < 0.05, loss  # measured: 2.3 cm over a 1.70 m flight
    # k = rho Cd pi r^2 / (2 m) for the default ball
    assert ball.drag_constant == pytest.approx(1.2 * 0.55 * math.pi * 0.033**2 / (2 * 0.057))


def test_fly_3d_equals_planar_in_any_direction():
    rng = np.random.default_rng(1)
    for z0, vh, vz, zl in random_releases(rng, 20):
        yaw = rng.uniform(-math.pi, math.pi)
        p0 = np.array([0.2, -0.1, z0])
        v0 = np.array([vh * math.cos(yaw), vh * math.sin(yaw), vz])
        land = fly(p0, v0, zl)
        s, t, vs, vzl = fly_planar(0.0, z0, vh, vz, zl)
        np.testing.assert_allclose(land.position, p0 + [s * math.cos(yaw), s * math.sin(yaw), zl - z0], atol=1e-12)
        assert land.position[2] == zl
        assert land.time == pytest.approx(t)
        np.testing.assert_allclose(land.velocity, [vs * math.cos(yaw), vs * math.sin(yaw), vzl], atol=1e-12)
        nd = landing_no_drag(p0, v0, zl)
        nd_planar = fly(p0, v0, zl, drag=False)
        np.testing.assert_allclose(nd.position, nd_planar.position, atol=1e-12)


def test_the_ball_comes_down_through_a_height_above_the_release():
    # released at 1.0 m going up at 4 m/s: apex 1.0 + 16 / (2 g) = 1.815 m; lands at 1.5 m on the way down
    _x, t, _, vz = fly_planar(0.0, 1.0, 1.0, 4.0, 1.5, Ball())
    assert vz < 0
    assert t > 4.0 / 9.81  # after the apex


def test_no_landing_is_a_clear_error():
    with pytest.raises(NoLandingError, match="apex"):
        fly_planar(0.0, 1.0, 2.0, 1.0, 2.0, Ball(), drag=False)
    with pytest.raises(NoLandingError, match="never"):
        fly_planar(0.0, 1.0, 2.0, 1.0, 2.0, Ball())
    with pytest.raises(NoLandingError):
        fly_planar(0.0, 0.2, 2.0, -1.0, 0.5, Ball())
    with pytest.raises(ThrowingError):
        fly([0, 0, 1], [1, 0], 0.0)
    with pytest.raises(ThrowingError):
        Ball(mass=0.0)


def test_flight_path_starts_at_release_and_ends_at_landing():
    p0, v0 = np.array([0.3, 0.0, 1.3]), np.array([2.5, 0.5, 1.0])
    times, pts = flight_path(p0, v0, 0.2, dt=0.01)
    land = fly(p0, v0, 0.2)
    np.testing.assert_allclose(pts[0], p0)
    np.testing.assert_allclose(pts[-1], land.position)
    assert times[-1] == pytest.approx(land.time)
    assert np.all(np.diff(times) > 0)
    # the path is in the vertical plane of the horizontal velocity
    d = pts[:, :2] - p0[:2]
    np.testing.assert_allclose(d[:, 0] * v0[1] - d[:, 1] * v0[0], 0.0, atol=1e-12)


def test_min_speed_throw_hits_the_target_and_nothing_slower_does():
    rng = np.random.default_rng(2)
    ball = Ball().without_drag()
    for _ in range(50):
        release = (rng.uniform(-0.2, 0.6), rng.uniform(1.0, 1.5))
        target = (rng.uniform(1.0, 2.0), rng.uniform(0.0, 0.4))
        v, a = min_speed_to_hit(release, target)
        x = fly_planar(*release, v * math.cos(a), v * math.sin(a), target[1], ball)[0]
        assert x == pytest.approx(target[0], abs=1e-9)
        # at 1 % less speed no angle reaches the target
        angles = np.linspace(-1.2, 1.4, 400)
        best = max(
            fly_planar(*release, 0.99 * v * math.cos(b), 0.99 * v * math.sin(b), target[1], ball)[0] for b in angles
        )
        assert best < target[0]


def test_speed_to_hit_without_and_with_drag():
    rng = np.random.default_rng(3)
    for _ in range(30):
        release = (rng.uniform(0.0, 0.6), rng.uniform(1.1, 1.4))
        target = (rng.uniform(1.0, 1.8), rng.uniform(0.0, 0.4))
        angle = math.radians(rng.uniform(-10, 45))
        v0 = speed_to_hit(release, angle, target, drag=False)
        x0 = fly_planar(*release, v0 * math.cos(angle), v0 * math.sin(angle), target[1], drag=False)[0]
        assert x0 == pytest.approx(target[0], abs=1e-9)
        v1 = speed_to_hit(release, angle, target)
        x1 = fly_planar(*release, v1 * math.cos(angle), v1 * math.sin(angle), target[1])[0]
        assert x1 == pytest.approx(target[0], abs=1e-8)
        assert v1 > v0  # drag costs speed
    with pytest.raises(UnreachableTargetError):
        speed_to_hit((0.0, 1.0), math.radians(-40), (1.5, 0.9))  # aimed below a target that is higher
