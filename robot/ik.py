"""Inverse kinematics for a position target: damped least squares with joint limits and restarts.

`solve_position(arm, frame, target, q0)` finds q such that the origin of `frame` is at `target`
(m, in `base`), with q inside the joint limits, or raises UnreachableError saying how close it got.

One iteration, with p(q) the frame position, J = dp/dq (3 x n, free joints only) and e = target - p:

    primary (Levenberg-Marquardt / damped least squares, Sugihara's damping):
        dq1 = J^T (J J^T + lambda^2 I)^-1 e,      lambda^2 = |e|^2 + lambda0^2
    secondary tasks, in the (damped) null space N = I - J^T (J J^T + lambda^2 I)^-1 J:
        facing:  gradient ascent on z(q) . d (z: the frame's z axis, d: the wanted direction)
                 d(z . d)/dq = Jw^T (z x d)      (Jw: the angular rows of the frame Jacobian)
        limits:  a pull towards the middle of the range for joints in the outer 5 % of it
    dq = dq1 + N g,   |dq|_inf <= max_step,   q <- clamp(q + dq)

Joints that would be pushed past a limit are clamped there and removed from J for that iteration
(then dq is recomputed), so the solver slides along the limits instead of sticking at them. When
an attempt stalls, the solver restarts from the seeded perturbations of q0 (then from uniform
random configurations); randomness comes only from `rng` (default: a Generator seeded with 0), so a
call is deterministic.
"""

from __future__ import annotations

import operator
from collections.abc import Sequence

import numpy as np
from numpy.typing import ArrayLike, NDArray

from wiithrow.robot.errors import RobotError, UnreachableError
from wiithrow.robot.model import ArmModel

LIMIT_ZONE = 0.05  # fraction of a joint's range, at each end, where the limit-avoidance pull acts


def _joint_indices(arm: ArmModel, joints: Sequence[int | str]) -> list[int]:
    out: list[int] = []
    for j in joints:
        if isinstance(j, str):
            if j not in arm.joint_names:
                raise RobotError(
                    f"unknown joint {j!r} in locked_joints; joints of '{arm.name}': {', '.join(arm.joint_names)}"
                )
            out.append(arm.joint_names.index(j))
            continue
        try:
            index = operator.index(j)  # an int or a numpy integer, not a float
        except TypeError:
            index = -1
        if not 0 <= index < arm.nq:
            raise RobotError(f"locked_joints entries must be joint names or indices 0..{arm.nq - 1}, got {j!r}")
        out.append(index)
    return sorted(set(out))


def _unit(v: ArrayLike, what: str) -> NDArray[np.float64]:
    a = np.asarray(v, dtype=np.float64)
    if a.shape != (3,) or not np.all(np.isfinite(a)) or np.linalg.norm(a) < 1e-12:
        raise RobotError(f"{what} must be a finite non-zero 3-vector, got {v!r}")
    return a / np.linalg.norm(a)


def solve_position(
    arm: ArmModel,
    frame: str,
    target_xyz: ArrayLike,
    q0: ArrayLike | None = None,
    *,
    locked_joints: Sequence[int | str] = (),
    tol: float = 1e-4,
    face_direction: ArrayLike | None = None,
    face_weight: float = 1.0,
    max_iter: int = 300,
    restarts: int = 12,
    max_step: float = 0.3,
    damping: float = 1e-3,
    rng: np.random.Generator | None = None,
) -> NDArray[np.float64]:
    """Joint configuration (nq,) that puts `frame`'s origin at `target_xyz` (m, in `base`).

    `q0`: start configuration (default `arm.home`; clamped into the limits); locked joints keep its
    values. `locked_joints`: names or indices of joints the solver must not move. `tol`: position
    tolerance (m). `face_direction`: optional (3,) direction in `base` that the frame's z axis should
    point along (e.g. the IR LED towards the cameras); a secondary task, honoured as far as the
    position task allows, weighted by `face_weight` (per-iteration gain, 0..1). `restarts`: how many
    seeded restarts after the first attempt. Raises UnreachableError (with the best distance reached)
    if no attempt gets within `tol`, RobotError for bad arguments.
    """
    target = np.asarray(target_xyz, dtype=float)
    if target.shape != (3,) or not np.all(np.isfinite(target)):
        raise RobotError(f"target_xyz must be a finite (3,) position in base, got {target_xyz!r}")
    if not tol > 0:
        raise RobotError(f"tol must be > 0, got {tol}")
    arm.frame_id(frame)  # a clear error for an unknown frame
    face = None if face_direction is None else _unit(face_direction, "face_direction")
    q_start = arm.clip(arm.home if q0 is None else q0)
    locked = _joint_indices(arm, locked_joints)
    movable = np.ones(arm.nq, dtype=bool)
    movable[locked] = False
    if not movable.any():
        raise RobotError("every joint is locked: nothing for the solver to move")
    rng = np.random.default_rng(0) if rng is None else rng

    best_q, best_dist = q_start.copy(), np.inf
    for attempt in range(restarts + 1):
        seed = _seed(arm, q_start, movable, attempt, restarts, rng)
        q, dist = _attempt(arm, frame, target, seed, movable, tol, face, face_weight, max_iter, max_step, damping)
        if dist < tol:
            return q
        if dist < best_dist:
            best_q, best_dist = q, dist
    raise UnreachableError(target, best_dist, frame, best_q)


def _seed(
    arm: ArmModel,
    q0: NDArray[np.float64],
    movable: NDArray[np.bool_],
    attempt: int,
    restarts: int,
    rng: np.random.Generator,
) -> NDArray[np.float64]:
    """Attempt 0: q0; the first half of the restarts: q0 + N(0, 0.5 rad); then uniform in the limits."""
    if attempt == 0:
        return q0.copy()
    if attempt <= restarts // 2:
        trial = q0 + rng.normal(0.0, 0.5, arm.nq)
    else:
        trial = rng.uniform(arm.lower, arm.upper)
    return np.where(movable, arm.clip(trial), q0)


def _attempt(
    arm: ArmModel,
    frame: str,
    target: NDArray[np.float64],
    q: NDArray[np.float64],
    movable: NDArray[np.bool_],
    tol: float,
    face: NDArray[np.float64] | None,
    face_weight: float,
    max_iter: int,
    max_step: float,
    damping: float,
) -> tuple[NDArray[np.float64], float]:
    """One damped-least-squares descent from q; returns (q, distance) of its best position iterate."""
    lo, hi = arm.lower, arm.upper
    mid, half = (lo + hi) / 2, (hi - lo) / 2
    best_q, best_dist, since_best = q.copy(), np.inf, 0
    settle, last_facing = 0, -2.0  # iterations spent on the facing task after the position converged
    for _ in range(max_iter):
        T, J6 = arm.frame_placement_and_jacobian(q, frame)
        e = target - T[:3, 3]
        dist = float(np.linalg.norm(e))
        if dist < tol:
            best_q, best_dist = q.copy(), dist
            if face is None:
                break
            # position reached: keep turning towards `face` until it stops improving
            facing = float(T[:3, 2] @ face)
            if settle >= max_iter // 2 or (settle > 0 and facing - last_facing < 1e-7):
                break
            last_facing, settle = facing, settle + 1
        elif dist < best_dist * (1 - 1e-3):
            best_q, best_dist, since_best = q.copy(), dist, 0
        else:
            since_best += 1
            if since_best >= 40:
                break  # stalled: let the caller restart elsewhere
        # secondary objective (joint space gradient, applied in the null space of the position task)
        g = np.zeros(arm.nq)
        if face is not None:
            z = T[:3, 2]
            g += face_weight * (J6[3:].T @ np.cross(z, face))
        u = (q - mid) / half  # -1 .. 1 across the range
        zone = np.abs(u) > 1 - 2 * LIMIT_ZONE
        g[zone] -= 0.2 * half[zone] * (u[zone] - np.sign(u[zone]) * (1 - 2 * LIMIT_ZONE))
        free = movable.copy()
        fixed_dq = np.zeros(arm.nq)  # steps of joints clamped at a limit in this iteration
        for _pass in range(4):
            J = J6[:3, free]
            lam2 = dist * dist + damping * damping
            A = J @ J.T + lam2 * np.eye(3)
            e_free = e - J6[:3] @ fixed_dq  # what the clamped joints' steps already do
            dq_free = J.T @ np.linalg.solve(A, e_free)
            N = np.eye(J.shape[1]) - J.T @ np.linalg.solve(A, J)
            dq_free += N @ g[free]
            dq = fixed_dq.copy()
            dq[free] = dq_free
            step = np.max(np.abs(dq))
            if step > max_step:
                dq *= max_step / step
            q_new = q + dq
            out = free & ((q_new < lo) | (q_new > hi))
            if not out.any():
                break
            # clamp those joints at their limit and solve again for the others
            fixed_dq[out] = np.clip(q_new[out], lo[out], hi[out]) - q[out]
            free &= ~out
            if not free.any():
                break
        q = np.clip(q_new, lo, hi)
    return best_q, best_dist
