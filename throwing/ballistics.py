"""Flight of the ball from its release state until it comes down through a given height.

Model (point mass, still air, gravity along -z of a frame whose z is up: `base` or `link1`):

    dp/dt = v,    dv/dt = -g e_z - k |v| v,    k = rho Cd A / (2 m),  A = pi r^2

(quadratic drag F = -1/2 rho Cd A |v| v divided by the mass m). Without drag (k = 0) the flight is
closed form:

    z(t) = z0 + vz t - g t^2 / 2,   landing at  t* = (vz + sqrt(vz^2 + 2 g (z0 - z*))) / g

(the later root: the ball *comes down* through z*). With drag, the motion stays in the vertical
plane spanned by e_z and the initial horizontal velocity direction u, so the flight is integrated
in 2D, (s, z) with s the horizontal distance along u, by fixed-step classical Runge-Kutta (RK4,
global error O(h^4)); in the step where z passes down through z*, Newton's method on the length
tau of a last RK4 step from the step's start, f(tau) = z(tau) - z*, f'(tau) ~ vz(tau), puts the
landing on the crossing to round-off. Plain Python floats: about 0.05-0.1 ms per flight at the
default step of 20 ms, fast enough for planning; the step is a setting (see
`tests/throwing/test_ballistics.py` for the measured convergence: 4th order, about 1e-9 m at 20 ms).

Inverse helpers in the throw plane (x horizontal, z up; any frame with z up):
- `min_speed_to_hit`: the slowest throw (speed, angle) from a release point through a target,
  closed form without drag:  v^2 = g (h + sqrt(h^2 + d^2)),  tan(angle) = (h + sqrt(h^2 + d^2)) / d,
  with d the horizontal distance and h the height of the target above the release point.
- `speed_to_hit`: the speed at a given release angle that lands on the target's x at its height;
  without drag v^2 = g d^2 / (2 cos^2(a) (d tan(a) - h)); with drag a few Newton steps from it.

Every position and velocity is in the frame the caller passes them in (SI units); the result is in
that same frame.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping
from dataclasses import asdict, dataclass, replace
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from wiithrow.throwing.errors import NoLandingError, ThrowingError, UnreachableTargetError

GRAVITY = 9.81  # m/s^2

#: Default RK4 step (s) of the drag integrator.
DEFAULT_STEP = 0.02
#: A flight longer than this (s) is refused as "never lands".
MAX_FLIGHT_TIME = 20.0


@dataclass(frozen=True)
class Ball:
    """The thrown ball and the air: SI units. Defaults: a tennis-like ball in room air."""

    radius: float = 0.033  # m
    mass: float = 0.057  # kg
    drag_coefficient: float = 0.55  # Cd, dimensionless
    air_density: float = 1.2  # rho, kg/m^3
    gravity: float = GRAVITY  # m/s^2, along -z

    def __post_init__(self) -> None:
        for name in ("radius", "mass", "gravity"):
            v = getattr(self, name)
            if not (math.isfinite(v) and v > 0):
                raise ThrowingError(f"Ball.{name} must be > 0, got {v}")
        for name in ("drag_coefficient", "air_density"):
            v = getattr(self, name)
            if not (math.isfinite(v) and v >= 0):
                raise ThrowingError(f"Ball.{name} must be >= 0, got {v}")

    @property
    def drag_constant(self) -> float:
        """k = rho Cd pi r^2 / (2 m) (1/m): the drag deceleration is k |v|^2."""
        return self.air_density * self.drag_coefficient * math.pi * self.radius**2 / (2.0 * self.mass)

    def without_drag(self) -> Ball:
        """The same ball in vacuum (drag coefficient 0)."""
        return replace(self, drag_coefficient=0.0)

    def to_dict(self) -> dict[str, float]:
        return asdict(self)

    @classmethod
    def from_dict(cls, d: Mapping[str, Any]) -> Ball:
        """The ball in `d`, a JSON object (its values are checked here); ThrowingError if it is not one."""
        try:
            return cls(**{k: float(d[k]) for k in ("radius", "mass", "drag_coefficient", "air_density", "gravity")})
        except (KeyError, TypeError, ValueError) as exc:
            raise ThrowingError(f"bad ball settings {d!r}: {exc}") from None


@dataclass(frozen=True)
class Landing:
    """Where and when the ball comes down through the landing height.

    `position` (3,) and `velocity` (3,) in the frame of the release state passed in (m, m/s);
    `time` (s) after release.
    """

    position: NDArray[np.float64]
    velocity: NDArray[np.float64]
    time: float


# ----- the planar core ---------------------------------------------------------------------------


def _no_drag_time(z0: float, vz: float, z_land: float, g: float) -> float:
    disc = vz * vz + 2.0 * g * (z0 - z_land)
    if disc < 0.0:
        apex = z0 + vz * vz / (2.0 * g) if vz > 0 else z0
        raise NoLandingError(
            f"the ball never reaches height {z_land:.4f} m: its apex is at {apex:.4f} m; throw higher or aim lower"
        )
    t = (vz + math.sqrt(disc)) / g
    if t < 0.0:  # starts below z_land moving down: the later root lies in the past
        raise NoLandingError(
            f"the ball starts at {z0:.4f} m, below {z_land:.4f} m, and moves down: it never lands there"
        )
    return t


def _rk4_step(
    s: float, z: float, vs: float, vz: float, h: float, k: float, g: float
) -> tuple[float, float, float, float]:
    """One classical RK4 step of ds = vs, dz = vz, dvs = -k |v| vs, dvz = -g - k |v| vz."""
    w1 = k * math.sqrt(vs * vs + vz * vz)
    a1s, a1z = -w1 * vs, -g - w1 * vz
    h2 = 0.5 * h
    vs2, vz2 = vs + h2 * a1s, vz + h2 * a1z
    w2 = k * math.sqrt(vs2 * vs2 + vz2 * vz2)
    a2s, a2z = -w2 * vs2, -g - w2 * vz2
    vs3, vz3 = vs + h2 * a2s, vz + h2 * a2z
    w3 = k * math.sqrt(vs3 * vs3 + vz3 * vz3)
    a3s, a3z = -w3 * vs3, -g - w3 * vz3
    vs4, vz4 = vs + h * a3s, vz + h * a3z
    w4 = k * math.sqrt(vs4 * vs4 + vz4 * vz4)
    a4s, a4z = -w4 * vs4, -g - w4 * vz4
    h6 = h / 6.0
    return (
        s + h6 * (vs + 2.0 * vs2 + 2.0 * vs3 + vs4),
        z + h6 * (vz + 2.0 * vz2 + 2.0 * vz3 + vz4),
        vs + h6 * (a1s + 2.0 * a2s + 2.0 * a3s + a4s),
        vz + h6 * (a1z + 2.0 * a2z + 2.0 * a3z + a4z),
    )


def fly_planar(
    x0: float,
    z0: float,
    vx0: float,
    vz0: float,
    z_land: float,
    ball: Ball | None = None,
    *,
    drag: bool = True,
    step: float = DEFAULT_STEP,
) -> tuple[float, float, float, float]:
    """Flight in a vertical plane from (x0, z0) with velocity (vx0, vz0) down through z = z_land.

    Returns (x, t, vx, vz) at the landing: horizontal position (m), time after release (s) and
    velocity (m/s). `drag=False` (or a ball with Cd = 0) uses the closed form. Raises
    NoLandingError if the ball never comes down through z_land.
    """
    ball = ball or Ball()
    g = ball.gravity
    k = ball.drag_constant if drag else 0.0
    x0, z0, vx0, vz0, z_land = float(x0), float(z0), float(vx0), float(vz0), float(z_land)
    if not all(math.isfinite(v) for v in (x0, z0, vx0, vz0, z_land)):
        raise ThrowingError("the release state and landing height must be finite")
    if k == 0.0:
        t = _no_drag_time(z0, vz0, z_land, g)
        return x0 + vx0 * t, t, vx0, vz0 - g * t
    if not step > 0:
        raise ThrowingError(f"the integration step must be > 0, got {step}")
    s, z, vs, vz, t = x0, z0, vx0, vz0, 0.0
    while True:
        if z < z_land and vz <= 0.0:
            raise NoLandingError(
                f"the ball never comes down through {z_land:.4f} m: it is at {z:.4f} m moving down at t = {t:.3f} s"
            )
        s1, z1, vs1, vz1 = _rk4_step(s, z, vs, vz, step, k, g)
        if z >= z_land > z1:  # the descending crossing lies in this step: Newton on the step length
            tau = step * (z - z_land) / (z - z1)
            for _ in range(8):
                s1, z1, vs1, vz1 = _rk4_step(s, z, vs, vz, tau, k, g)
                if vz1 >= 0.0:
                    break
                d = (z1 - z_land) / vz1
                tau = min(max(tau - d, 0.0), step)
                if abs(d) < 1e-13:
                    break
            s1, z1, vs1, vz1 = _rk4_step(s, z, vs, vz, tau, k, g)
            return s1, t + tau, vs1, vz1
        s, z, vs, vz, t = s1, z1, vs1, vz1, t + step
        if t > MAX_FLIGHT_TIME:
            raise NoLandingError(f"the ball has not come down through {z_land:.4f} m after {MAX_FLIGHT_TIME} s")


# ----- 3D ----------------------------------------------------------------------------------------


def _vec3(v: ArrayLike, what: str) -> NDArray[np.float64]:
    a = np.asarray(v, dtype=np.float64)
    if a.shape != (3,) or not np.all(np.isfinite(a)):
        raise ThrowingError(f"{what} must be a finite (3,) vector, got {np.shape(v)}")
    return a


def _release(
    position: ArrayLike, velocity: ArrayLike
) -> tuple[NDArray[np.float64], NDArray[np.float64], float, NDArray[np.float64]]:
    """(p0, v0, vh, u): the checked release position and velocity (3,), the horizontal speed vh and
    its unit direction u (3,) (x when the ball goes straight up): the vertical plane of the flight."""
    p0 = _vec3(position, "release position")
    v0 = _vec3(velocity, "release velocity")
    vh = math.hypot(v0[0], v0[1])
    u = np.array([v0[0] / vh, v0[1] / vh, 0.0]) if vh > 0 else np.array([1.0, 0.0, 0.0])
    return p0, v0, vh, u


def fly(
    position: ArrayLike,
    velocity: ArrayLike,
    z_land: float,
    ball: Ball | None = None,
    *,
    drag: bool = True,
    step: float = DEFAULT_STEP,
) -> Landing:
    """Flight from a release `position` (3,) and `velocity` (3,) down through the height `z_land`.

    Positions in any frame with z up and gravity along -z (`base`, `link1`); the landing is in the
    same frame. The flight stays in the vertical plane of the initial horizontal velocity u, so it
    is integrated in that plane (`fly_planar`) and mapped back: p = p0 + s u + (z - z0) e_z.
    """
    p0, v0, vh, u = _release(position, velocity)
    s, t, vs, vz = fly_planar(0.0, p0[2], vh, v0[2], z_land, ball, drag=drag, step=step)
    pos = p0 + s * u
    pos[2] = float(z_land)
    vel = vs * u
    vel[2] = vz
    return Landing(pos, vel, t)


def landing_no_drag(position: ArrayLike, velocity: ArrayLike, z_land: float, gravity: float = GRAVITY) -> Landing:
    """Closed-form landing without drag (see the module docstring); same frames as `fly`."""
    p0 = _vec3(position, "release position")
    v0 = _vec3(velocity, "release velocity")
    t = _no_drag_time(float(p0[2]), float(v0[2]), float(z_land), gravity)
    pos = p0 + v0 * t
    pos[2] = float(z_land)
    vel = v0.copy()
    vel[2] -= gravity * t
    return Landing(pos, vel, t)


def flight_path(
    position: ArrayLike,
    velocity: ArrayLike,
    z_land: float,
    ball: Ball | None = None,
    *,
    drag: bool = True,
    dt: float = 0.01,
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """(times (T,), positions (T, 3)) of the ball every `dt` s from release to its landing
    (the last sample is the landing itself); for drawing and animation. Frames as in `fly`."""
    landing = fly(position, velocity, z_land, ball, drag=drag)
    p0, v0, vh, u = _release(position, velocity)
    ball = ball or Ball()
    k = ball.drag_constant if drag else 0.0
    times = np.append(np.arange(0.0, landing.time, dt), landing.time)
    pts = np.empty((times.size, 3))
    s, z, vs, vz = 0.0, float(p0[2]), vh, float(v0[2])
    h = min(dt, DEFAULT_STEP)
    t = 0.0
    for i, ti in enumerate(times):
        while t < ti - 1e-12:
            hh = min(h, ti - t)
            s, z, vs, vz = _rk4_step(s, z, vs, vz, hh, k, ball.gravity)
            t += hh
        pts[i] = p0 + s * u
        pts[i, 2] = z
    pts[-1] = landing.position
    return times, pts


# ----- inverse ballistics in the throw plane -----------------------------------------------------


def min_speed_to_hit(
    release_xz: Iterable[float], target_xz: Iterable[float], gravity: float = GRAVITY
) -> tuple[float, float]:
    """(speed m/s, angle rad above horizontal) of the slowest drag-free throw from `release_xz`
    through `target_xz` (both (x, z) in the throw plane). The ball passes the target descending.

        v^2 = g (h + sqrt(h^2 + d^2)),   tan(angle) = (h + sqrt(h^2 + d^2)) / d
    """
    x0, z0 = (float(v) for v in release_xz)
    xt, zt = (float(v) for v in target_xz)
    d, h = xt - x0, zt - z0
    if not d > 0:
        raise UnreachableTargetError(f"the target must lie ahead of the release point (d = {d:.4f} m)")
    r = math.hypot(d, h)
    return math.sqrt(gravity * (h + r)), math.atan2(h + r, d)


def speed_to_hit(
    release_xz: Iterable[float],
    angle: float,
    target_xz: Iterable[float],
    ball: Ball | None = None,
    *,
    drag: bool = True,
    tol: float = 1e-9,
    max_iter: int = 20,
) -> float:
    """Release speed (m/s) at `angle` (rad above horizontal) whose ball comes down through the
    target's height at the target's x. Closed form without drag (module docstring), then Newton
    steps on the speed with drag (derivative by a central difference), to |x - x_target| < tol.
    Raises UnreachableTargetError when no speed at this angle reaches the target.
    """
    ball = ball or Ball()
    x0, z0 = (float(v) for v in release_xz)
    xt, zt = (float(v) for v in target_xz)
    d, h = xt - x0, zt - z0
    c, sa = math.cos(angle), math.sin(angle)
    denom = 2.0 * c * c * (d * math.tan(angle) - h) if abs(c) > 1e-12 else 0.0
    if not (d > 0 and denom > 0):
        raise UnreachableTargetError(
            f"no throw at {math.degrees(angle):.1f} deg from ({x0:.3f}, {z0:.3f}) m reaches ({xt:.3f}, {zt:.3f}) m; "
            "throw steeper"
        )
    v = math.sqrt(ball.gravity * d * d / denom)
    if not drag or ball.drag_constant == 0.0:
        return v

    def miss(speed: float) -> float:
        x, _, _, _ = fly_planar(x0, z0, speed * c, speed * sa, zt, ball)
        return x - xt

    for _ in range(max_iter):
        try:
            f = miss(v)
            if abs(f) < tol:
                return v
            e = 1e-6 * v
            df = (miss(v + e) - miss(v - e)) / (2 * e)
        except NoLandingError:
            df = 0.0
        if not df > 0:
            break
        v -= f / df
    raise UnreachableTargetError(
        f"Newton on the release speed did not converge for a throw at {math.degrees(angle):.1f} deg "
        f"from ({x0:.3f}, {z0:.3f}) m to ({xt:.3f}, {zt:.3f}) m with drag"
    )
