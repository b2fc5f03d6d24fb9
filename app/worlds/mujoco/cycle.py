"""The lab's servo cycle compiled (numba): a stretch of 1 kHz servo periods for the cost of MuJoCo's
`mj_step` and little else. Owns the arithmetic of one period and its loop, nothing else: the lab
(`lab.MujocoLab`) decides how many periods run, what is watched, and does every event in Python.

Why compiled: one period of the velocity-mode arm is a handful of operations on seven joints; in
numpy each costs its fixed 1-2 us per call, so the servo and the host's law cost several times
the physics (measured: 60 ms of CPU per simulated second, `mj_step` about 10 of it). Here the
loop calls `mj_step` from compiled code (the C function of the `libmujoco` the `mujoco` package
loaded, on the `MjModel`/`MjData` addresses) and the arithmetic costs nanoseconds.

One period k (time t_k), per joint j, exactly the operations (and their order) of the host's
`wiithrow.robot.velocity_mode.VelocityModeArm._control` and of the servo amplifier
(`servo.VelocityPI`, whose docstring has the loop's equations):

    host:  v_c = min(max(v_ref + K_p (q_ref - q), -v_max), v_max)     (q_ref, v_ref at t_k)
    servo: e = v_c - dq;  tau = K_v (e + w_i s);  saturated: tau clipped, s not integrated while
           e tau > 0 (anti-windup);  else  s <- s + e h
    then   ctrl <- tau;  mj_step

(q, dq) are the encoders before the step. Without a host (`host` False) v_c is what the caller
left in `v_command` (a host called per period from Python, or rest). The reference comes from
the host as rows (q_ref, v_ref) per period, or one row for all (a host at rest).

That is the amplifier (`SERVO_TORQUE`). When the servo is in the model (`arm_servo`), the period
has no amplifier: a velocity servo's control is the host's v_c above (`SERVO_VELOCITY`), a position
servo's is the host's setpoint, given as the rows of q_ref (`SERVO_POSITION`); either is kept in
`v_command` and written to the arm's controls, then `mj_step`.

The host of a compiled run is a `VelocityLaw` (the arm driver over a torque or velocity servo,
`devices.MujocoArm`) or a `SetpointLaw` (over a position servo, `devices.MujocoPositionArm`).

Watching (`watch`): after each step the loop returns early, when the model's contact sensors
(`model.BuiltModel.pad_sensors`, `surface_sensors`: how many contacts the ball has with each pad,
with the floor and the table) say: `WATCH_RELEASE`, no pad touches the ball any more;
`WATCH_TOUCHDOWN`, the ball touches the floor or the table. The lab then looks at that step as
it looked at every step before (`lab.MujocoLab._watch_ball`). The ball's path (a point every
10 ms in flight, for drawing) is recorded in the loop (`PathRecording`), so that a run does not
stop for it.

`cache=True` keeps the compiled code between runs: `mj_step` is called through a symbol
registered with LLVM at import (`llvmlite.binding.add_symbol`), not a ctypes pointer, which numba
would refuse to cache. MjModel and MjData are passed as addresses (`_address`), declared as
integers: on the C ABIs MuJoCo builds for a pointer and an intptr_t travel alike.

The poses (`POSE_COLUMNS`): after each step the loop writes link1's pose and the hand LED's position
into a ring of rows, so that a remote whose report falls due inside a long run (a real-time world
catching up after its host was not scheduled for a while) sees the LEDs where they were at the
report's time, as a real camera does, not where they are when the run ends.
"""

from __future__ import annotations

import ctypes
import os
from typing import Any, Protocol, runtime_checkable

import llvmlite.binding as llvm  # type: ignore[import-untyped]
import mujoco
import numpy as np
from numba import njit, types
from numpy.typing import NDArray

#: What the loop watches after each step (module docstring).
WATCH_NOTHING, WATCH_RELEASE, WATCH_TOUCHDOWN = 0, 1, 2

#: What the arm's actuators take (`arm_servo.SERVO_KINDS`, in this order): torques from the
#: amplifier's PI velocity loop (`servo.VelocityPI`, the project's), a velocity command (MuJoCo
#: `velocity` actuators, the servo in the model), a position setpoint (a joint PD: `position`
#: actuators, or `general` ones with a bias).
SERVO_TORQUE, SERVO_VELOCITY, SERVO_POSITION = 0, 1, 2


def _libmujoco_path() -> str:
    """The `libmujoco.so.*` (or .dylib, .dll) inside the installed `mujoco` package."""
    folder = os.path.dirname(mujoco.__file__)
    names = sorted(n for n in os.listdir(folder) if n.startswith(("libmujoco", "mujoco.dll")))
    if not names:
        raise ImportError(f"no libmujoco library in {folder}")
    return os.path.join(folder, names[0])


_LIB = ctypes.CDLL(_libmujoco_path())
llvm.add_symbol("mj_step", ctypes.cast(_LIB.mj_step, ctypes.c_void_p).value)
_mj_step: Any = types.ExternalFunction("mj_step", types.void(types.intp, types.intp))

Floats = NDArray[np.float64]


@runtime_checkable
class VelocityLaw(Protocol):
    """A host whose controller is the velocity-mode law v_c = min(max(v_ref + K_p (q_ref - q),
    -v_max), v_max) (`wiithrow.robot.velocity_mode`), asked for its reference many periods at once."""

    position_gain: float  # K_p, 1/s
    velocity_limit: NDArray[np.float64]  # v_max per joint, rad/s

    def references(self, times: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """(q_ref, v_ref) at the periods starting at `times`: one row per time, or one row for all."""
        ...

    def commanded(self, v_command: NDArray[np.float64], periods_run: int) -> None:
        """The command of the last period that ran (the host keeps it), and how many of the
        periods of the last `references` ran (a run ends early at a watched event: the host
        takes back the reference of the others)."""
        ...


@runtime_checkable
class SetpointLaw(Protocol):
    """A host that feeds a position servo (`SERVO_POSITION`) its setpoints, asked for them many
    periods at once (`wiithrow.robot.position_mode`; the MuJoCo driver `devices.MujocoPositionArm`)."""

    def setpoints(self, times: NDArray[np.float64]) -> NDArray[np.float64]:
        """The setpoints (rad) of the periods starting at `times`: one row per time, or one row for all."""
        ...

    def commanded(self, v_command: NDArray[np.float64], periods_run: int) -> None:
        """The setpoint of the last period that ran, and how many of the periods of the last
        `setpoints` ran (as `VelocityLaw.commanded`)."""
        ...


#: A step's pose in the ring of `run_periods` (row `k % len`, k the step): link1's origin (3) and
#: orientation (9, row-major) in base, and the hand's LED's position (3) in base: what a remote
#: reporting at that step's time saw, read back when its report is made later (`lab.MujocoLab`).
POSE_COLUMNS = 15

#: The ball's path recorded in the loop, a tuple: (record: bool, t0: float, k0: int, h: float,
#: last: float, every: float, touchdown_at: float, after: float, ball_qpos: int, times (m,),
#: points (m, 3), count (1,) int). After the step that ends period k0 + i + 1, at its time
#: t = t0 + (k0 + i + 1) h (the lab's `t`, the same operations), the ball's position (qpos at
#: ball_qpos) is put in the next row when t - last >= every and t - touchdown_at <= after (the
#: lab's `_watch_ball` test: a point every 10 ms from the release until 1 s after the
#: touchdown; touchdown_at +inf before it); last becomes t. count[0]: the rows filled.
PathRecording = tuple[bool, float, int, float, float, float, float, float, int, Floats, Floats, NDArray[np.int64]]


@njit(cache=True)
def run_periods(
    n: int,
    servo_kind: int,
    watch: int,
    host: bool,
    q_ref: Floats,
    v_ref: Floats,
    position_gain: float,
    v_limit: Floats,
    path: PathRecording,
    model: int,
    data: int,
    qpos: Floats,
    qvel: Floats,
    ctrl: Floats,
    sensordata: Floats,
    arm_qpos: int,
    arm_dof: int,
    arm_ctrl: int,
    v_command: Floats,
    gain: Floats,
    integral_rate: float,
    integral: Floats,
    torque_limit: Floats,
    period: float,
    pad_sensors: NDArray[np.int64],
    surface_sensors: NDArray[np.int64],
    counters: NDArray[np.int64],
    xpos: Floats,
    xmat: Floats,
    site_xpos: Floats,
    link1_body: int,
    hand_site: int,
    poses: Floats,
) -> int:
    """Run up to `n` servo periods (module docstring) on the MjData at address `data` (the
    arguments from `model` on are the same for every run of a lab: `lab.MujocoLab` passes them as
    one tuple it made once); return how
    many ran (fewer when the watched event happened in the last one). `qpos`, `qvel`, `ctrl`,
    `sensordata` are that MjData's arrays; `v_command` and `integral` are updated in place;
    `counters[0]` counts the periods in which the servo saturated; the ball's path points go
    into `path` (`PathRecording`); the pose of each step goes into the ring `poses` (`POSE_COLUMNS`)."""
    (record, t0, k0, h, path_last, path_every, touchdown_at, path_after, ball_qpos, path_t, path_points, recorded) = (
        path
    )
    recorded[0] = 0
    nj = v_command.shape[0]
    e = np.empty(nj)
    tau = np.empty(nj)
    per_period = q_ref.shape[0] > 1
    for i in range(n):
        if servo_kind != SERVO_TORQUE:  # the servo is in the model: its actuators take the command
            if host:
                r = i if per_period else 0
                for j in range(nj):
                    if servo_kind == SERVO_POSITION:  # the host's setpoint rows (q_ref)
                        v_command[j] = q_ref[r, j]
                    else:
                        v = v_ref[r, j] + position_gain * (q_ref[r, j] - qpos[arm_qpos + j])
                        v = max(v, -v_limit[j])
                        v_command[j] = min(v, v_limit[j])
            for j in range(nj):
                ctrl[arm_ctrl + j] = v_command[j]
        else:  # the amplifier: the host's velocity law, then the PI loop gives the torques
            if host:
                r = i if per_period else 0
                for j in range(nj):
                    v = v_ref[r, j] + position_gain * (q_ref[r, j] - qpos[arm_qpos + j])
                    v = max(v, -v_limit[j])
                    v_command[j] = min(v, v_limit[j])
            saturated = False
            for j in range(nj):
                e[j] = v_command[j] - qvel[arm_dof + j]
                tau[j] = gain[j] * (e[j] + integral_rate * integral[j])
                if abs(tau[j]) > torque_limit[j]:
                    saturated = True
            if saturated:
                counters[0] += 1
                for j in range(nj):
                    limit = torque_limit[j]
                    clipped = min(max(tau[j], -limit), limit)
                    if not (abs(tau[j]) > limit and e[j] * clipped > 0):
                        integral[j] += e[j] * period
                    tau[j] = clipped
            else:
                for j in range(nj):
                    integral[j] += e[j] * period
            for j in range(nj):
                ctrl[arm_ctrl + j] = tau[j]
        _mj_step(model, data)
        slot = (k0 + i + 1) % poses.shape[0]  # the step's pose (`POSE_COLUMNS`), as Python reads it after it
        for j in range(3):
            poses[slot, j] = xpos[link1_body, j]
            poses[slot, 12 + j] = site_xpos[hand_site, j]
        for j in range(9):
            poses[slot, 3 + j] = xmat[link1_body, j]
        if record:  # the ball's path: (t, ball position) when due (`PathRecording`)
            t = t0 + (k0 + i + 1) * h
            if t - path_last >= path_every and t - touchdown_at <= path_after:
                row = recorded[0]
                path_t[row] = t
                for j in range(3):
                    path_points[row, j] = qpos[ball_qpos + j]
                recorded[0] = row + 1
                path_last = t
        if watch == WATCH_RELEASE:
            touching = 0.0
            for s in pad_sensors:
                touching += sensordata[s]
            if touching == 0.0:
                return i + 1
        elif watch == WATCH_TOUCHDOWN:
            for s in surface_sensors:
                if sensordata[s] > 0.0:
                    return i + 1
    return n
