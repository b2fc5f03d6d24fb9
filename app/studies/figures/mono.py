"""Fig. 6: the mono method against the stereo rig while the hand turns the beacon pair.

The hand carries two IR beacons 0.15 m apart along its marker frame's x axis (`beacon_a`,
`beacon_b` of the world). It holds their midpoint still, first with the beacon line parallel to
cam0's image plane (the line along the image's x axis, the LED axis against the optical axis),
then turned by theta about the image's vertical axis:

    R_marker(theta) = Rot(r_2, theta) [x_0  y_0  z_0]     (r_2: cam0's image y axis in link1)

so the line leaves the image plane by theta. At each angle the arm stops, `frames` frames of
both cameras are averaged, and the midpoint is measured
- by the mono method (`vision.mono_position` with cam0's calibrated K, R, t: depth
  Z = D / ||n_a - n_b||, which assumes theta = 0 and so comes out about Z / cos(theta)),
- by the stereo rig (both beacons triangulated with the calibration, their midpoint),
and compared with forward kinematics. Depth errors are along cam0's optical axis.

The midpoint sits between the cameras, off cam0's axis by X0 (about 0.125 m), so the mono error is
not quite the on-axis Z (1/cos(theta) - 1): with the beacons at depths Z0 -+ d sin(theta) and
lateral offsets X0 +- d cos(theta) (d = D / 2), similar triangles give

    Z_mono = (Z0^2 - d^2 sin^2 theta) / (Z0 cos theta + X0 sin theta),

which the measured curve follows (a small dip below zero at small angles, then the steep rise).

Reaching an orientation needs a position-and-orientation IK (`solve_pose`, damped least squares
on the 6D error, joint 1 locked), which `robot.solve_position` (position plus a facing direction)
does not offer; it lives here because only this figure needs it.
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.spatial.transform import Rotation

from wiithrow.app.errors import AppError
from wiithrow.app.progress import progress_bar
from wiithrow.app.rig.waiting import pump, wait_while_moving
from wiithrow.app.settings import Settings
from wiithrow.app.studies.figures import new_figure, save_png, write_csv
from wiithrow.app.worlds import SimWorld
from wiithrow.robot import ArmModel, RobotError, solve_position
from wiithrow.vision import StereoCalibration, mono_position, triangulate

BEACON_DISTANCE_M = 0.15


def solve_pose(
    arm: ArmModel,
    frame: str,
    R_target: NDArray[np.float64],
    p_target: NDArray[np.float64],
    q0: NDArray[np.float64],
    *,
    locked: tuple[int, ...] = (0,),
    tol_m: float = 1e-4,
    tol_rad: float = 1e-3,
    max_iter: int = 300,
    damping: float = 1e-2,
) -> NDArray[np.float64]:
    """q putting `frame` at (R_target, p_target) (in base), by damped least squares:

        e = [p* - p(q);  log(R* R(q)^T)],   dq = J^T (J J^T + lambda^2 I)^-1 e   (free joints)

    (J in LOCAL_WORLD_ALIGNED, whose angular rows match the world-frame rotation error).
    Raises RobotError if it does not converge within the limits.
    """
    q = arm.clip(q0)
    free = np.ones(arm.nq, dtype=bool)
    free[list(locked)] = False
    for _ in range(max_iter):
        T, J = arm.frame_placement_and_jacobian(q, frame)
        e = np.concatenate([p_target - T[:3, 3], Rotation.from_matrix(R_target @ T[:3, :3].T).as_rotvec()])
        if np.linalg.norm(e[:3]) < tol_m and np.linalg.norm(e[3:]) < tol_rad:
            return q
        Jf = J[:, free]
        dq = np.zeros(arm.nq)
        dq[free] = Jf.T @ np.linalg.solve(Jf @ Jf.T + damping**2 * np.eye(6), e)
        step = np.abs(dq).max()
        if step > 0.2:
            dq *= 0.2 / step
        q = arm.clip(q + dq)
    raise RobotError(f"no configuration puts '{frame}' at {np.round(p_target, 3)} m with the asked orientation")


@dataclass(frozen=True)
class MonoVsStereo:
    """Per angle (K,): the true beacon-line angle to cam0's image plane (deg), the true midpoint,
    the stereo and the mono estimates (K, 3) in link1, and the true depth and lateral offset (along
    the image's x axis) of the midpoint in cam0 (m)."""

    angle_deg: NDArray[np.float64]
    true: NDArray[np.float64]
    stereo: NDArray[np.float64]
    mono: NDArray[np.float64]
    depth_m: NDArray[np.float64]
    lateral_m: NDArray[np.float64]
    optical_axis: NDArray[np.float64]

    def mono_model_depth_error(self, angle_deg: NDArray[np.float64]) -> NDArray[np.float64]:
        """Z_mono - Z0 of the similar-triangles model (module docstring) at the median depth and offset."""
        theta = np.deg2rad(angle_deg)
        z0, x0, d = float(np.median(self.depth_m)), float(np.median(self.lateral_m)), BEACON_DISTANCE_M / 2
        return (z0**2 - d**2 * np.sin(theta) ** 2) / (z0 * np.cos(theta) + x0 * np.sin(theta)) - z0

    def depth_error(self, which: str) -> NDArray[np.float64]:
        """Signed depth error (K,) along cam0's optical axis, m: estimate - truth."""
        est = self.stereo if which == "stereo" else self.mono
        return (est - self.true) @ self.optical_axis

    def position_error(self, which: str) -> NDArray[np.float64]:
        est = self.stereo if which == "stereo" else self.mono
        return np.linalg.norm(est - self.true, axis=1)


def _measure_beacons(world, frames: int, step: float) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Average `frames` frames per camera: pixels (C, 2 beacons, 2) by dot slot, and the mean
    marker position (link1) by FK over the same time."""
    t0 = world.clock.now()
    qs = [world.arm.state().q.copy()]
    C = len(world.rig.camera_names)

    def enough() -> bool:
        return all(sum(f.t > t0 for f in world.rig.recent(c, frames)) >= frames for c in range(C))

    def record() -> None:
        qs.append(world.arm.state().q.copy())

    waited = 0.0
    while not enough():
        pump(world.clock, world.rig, step, on_step=record)
        waited += step
        if waited > 5.0:
            raise AppError("the simulated remotes stopped sending frames")
    pixels = np.full((C, 2, 2), np.nan)
    for c in range(C):
        recent = [f for f in world.rig.recent(c, frames) if f.t > t0]
        two = [f.dots[f.visible] for f in recent if int(f.visible.sum()) == 2]
        if len(two) * 2 > len(recent):
            pixels[c] = np.mean(two, axis=0)
    truth = np.mean([world.base_to_link1(world.arm_model.frame_position(q, "marker"), q)[0] for q in qs], axis=0)
    return pixels, truth


def _stereo_midpoint(Ps: NDArray[np.float64], pixels: NDArray[np.float64]) -> NDArray[np.float64]:
    """Midpoint of the two beacons triangulated from pixels (C, 2, 2); the beacons are matched
    across cameras by the pairing with the smaller reprojection error."""
    best, best_err = np.full(3, np.nan), np.inf
    for swap in (False, True):
        x = pixels.copy()
        if swap:
            x[1:] = x[1:, ::-1]
        tri = triangulate(Ps, x)
        err = float(np.sum(tri.reprojection_error_px))
        if np.isfinite(err) and err < best_err:
            best, best_err = tri.points.mean(axis=0), err
    return best


def mono_vs_stereo(
    world,
    calibration: StereoCalibration,
    *,
    angles_deg: NDArray[np.float64] | None = None,
    center_link1: tuple[float, float, float] = (0.70, 0.0, 0.30),
    frames: int = 10,
    settle_s: float = 0.3,
    step_s: float = 0.01,
    show_progress: bool = True,
) -> MonoVsStereo:
    """Fig. 6's data on a `SimWorld` whose rig is calibrated by `calibration` (see the docstring)."""
    angles = np.arange(0.0, 76.0, 5.0) if angles_deg is None else np.asarray(angles_deg, dtype=float)
    for name in ("marker", "target", "landing"):
        world.light(name, False)
    world.light("beacon_a")
    world.light("beacon_b")
    cam0 = calibration.cameras[0].decompose()
    p0 = np.asarray(center_link1, dtype=float)
    # theta = 0: the beacon line along the image's x axis (parallel to the image plane), the LED
    # axis against the optical axis (towards the camera)
    x0, z0 = cam0.R[0], -cam0.R[2]
    R0 = np.column_stack([x0, np.cross(z0, x0), z0])
    axis = cam0.R[1] / np.linalg.norm(cam0.R[1])
    true_axis = world.cameras[0].R[2]
    model = world.arm_model
    seed = model.home.copy()  # from the home posture (not wherever the arm is): one wrist branch
    seed[0] = world.arm.state().q[0]
    T1 = model.frame_placement(seed, "link1")
    R1, o1 = T1[:3, :3], T1[:3, 3]
    try:
        start = solve_position(model, "marker", R1 @ p0 + o1, seed, locked_joints=(0,), face_direction=R1 @ z0)
    except RobotError as exc:
        raise AppError(f"Fig. 6: the hand cannot hold the beacons at {p0.tolist()} m (link1): {exc}") from None
    rng = np.random.default_rng(0)
    q = start
    rows = []
    for theta in progress_bar(angles, show=show_progress, desc="Fig. 6 beacon angles", unit="pose", leave=False):
        R_link1 = Rotation.from_rotvec(np.deg2rad(theta) * axis).as_matrix() @ R0
        seeds = [q, start] + [
            np.where(np.arange(model.nq) == 0, start, start + rng.normal(0, 0.5, model.nq)) for _ in range(4)
        ]
        found = _first_pose(model, R1 @ R_link1, R1 @ p0 + o1, seeds)
        if found is None:
            q = start
            continue  # beyond the wrist's reach at this angle: leave it out
        q = found
        world.arm.command_position(q)
        if not wait_while_moving(world.arm, world.clock, world.rig, timeout_s=30.0, step_s=step_s):
            world.arm.stop()
            raise AppError("Fig. 6: the arm did not reach a beacon pose within 30 s")
        pump(world.clock, world.rig, settle_s)
        pixels, truth = _measure_beacons(world, frames, step_s)
        if not np.isfinite(pixels).all():
            continue  # a beacon left a camera's view
        mono = mono_position(pixels[0, 0], pixels[0, 1], BEACON_DISTANCE_M, cam0.K, cam0.R, cam0.t)[0]
        stereo = _stereo_midpoint(calibration.Ps, pixels)
        x_axis = R1.T @ model.frame_placement(world.arm.state().q, "marker")[:3, 0]
        angle = np.degrees(np.arcsin(min(1.0, abs(float(x_axis @ true_axis)))))
        depth = float((truth - world.cameras[0].center) @ true_axis)
        lateral = float((truth - world.cameras[0].center) @ world.cameras[0].R[0])
        rows.append((angle, truth, stereo, mono, depth, lateral))
    world.light("beacon_a", False)
    world.light("beacon_b", False)
    if not rows:
        raise AppError("Fig. 6: no beacon pose could be measured")
    a, t, s, m, d, x = zip(*rows)
    return MonoVsStereo(np.array(a), np.array(t), np.array(s), np.array(m), np.array(d), np.array(x), true_axis)


def write_fig6(data: MonoVsStereo, out_dir: str | os.PathLike[str]) -> list[Path]:
    """fig6_mono_vs_stereo.csv and .png (depth and position error against the beacon angle)."""
    out_dir = Path(out_dir)
    rows = []
    for k in range(len(data.angle_deg)):
        rows.append(
            (
                float(data.angle_deg[k]),
                float(data.depth_m[k]),
                *map(float, data.true[k]),
                *map(float, data.stereo[k]),
                *map(float, data.mono[k]),
                float(data.depth_error("stereo")[k]),
                float(data.depth_error("mono")[k]),
            )
        )
    csv_path = write_csv(
        out_dir / "fig6_mono_vs_stereo.csv",
        [
            "beacon_angle_deg",
            "true_depth_m",
            "x_true_m",
            "y_true_m",
            "z_true_m",
            "x_stereo_m",
            "y_stereo_m",
            "z_stereo_m",
            "x_mono_m",
            "y_mono_m",
            "z_mono_m",
            "stereo_depth_error_m",
            "mono_depth_error_m",
        ],
        rows,
    )
    fig = new_figure(9.0, 4.2)
    left, right = fig.add_subplot(1, 2, 1), fig.add_subplot(1, 2, 2)
    theta = data.angle_deg
    for which, style in (("stereo", "o-"), ("mono", "s-")):
        left.plot(theta, 1e3 * data.depth_error(which), style, label=which)
        right.plot(theta, 1e3 * data.position_error(which), style, label=which)
    z = np.median(data.depth_m)
    model = np.linspace(0, theta.max(), 100)
    left.plot(model, 1e3 * data.mono_model_depth_error(model), "k-", lw=0.7, label="mono, similar-triangles model")
    left.plot(
        model,
        1e3 * z * (1 / np.cos(np.deg2rad(model)) - 1),
        "k:",
        lw=0.8,
        label="same on the optical axis: Z (1/cos - 1)",
    )
    left.set_ylabel("depth error in cam0 (mm)")
    right.set_ylabel("3D position error (mm)")
    right.set_yscale("log")
    for ax in (left, right):
        ax.set_xlabel("beacon line's angle to the image plane (deg)")
        ax.grid(True, alpha=0.3)
        ax.legend(fontsize=8)
    fig.suptitle("Fig. 6: mono method (one camera, two beacons 0.15 m apart) against the stereo rig")
    return [csv_path, save_png(fig, out_dir / "fig6_mono_vs_stereo.png")]


def _first_pose(
    model: ArmModel, rotation: NDArray[np.float64], position: NDArray[np.float64], seeds: list[NDArray[np.float64]]
) -> NDArray[np.float64] | None:
    """The first configuration `solve_pose` finds from the seeds, in order; None if none works."""
    for seed in seeds:
        try:
            return solve_pose(model, "marker", rotation, position, seed)
        except RobotError:
            continue
    return None


def study_mono_vs_stereo(
    settings: Settings, calibration: StereoCalibration, *, angles_deg: ArrayLike | None = None, seed: int = 0
) -> MonoVsStereo:
    """Fig. 6 (the mono method against the stereo rig) measured on a simulated twin of a world:
    the same `settings`, its own arm, rig and simulated clock, tracking with `calibration`. It never
    touches a running world, so it may run in another thread or process while operations run."""
    twin = SimWorld(settings, seed=seed, calibration=calibration)
    try:
        twin.connect()
        angles = None if angles_deg is None else np.asarray(angles_deg, dtype=float)
        return mono_vs_stereo(twin, calibration, angles_deg=angles, show_progress=False)
    finally:
        twin.close()
