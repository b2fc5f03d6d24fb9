"""The MuJoCo world's physics on the world's clock: one `MujocoLab` per world, shared by the devices
that live in it (the arm's servo, the hand, the LEDs the remotes see) and by the simulated
operator (who hands the ball to the gripper and puts a marker where it came down).

Owns the `mujoco.MjData` and advances it lazily, like `robot.SimulatedArm`: whenever anything reads
the lab, it steps the physics up to the clock's now, one servo period h (1 ms) at a time. One step:

1. the host's controller (the arm driver attached with `attach_host`, as on the real PA-10's
   1 kHz velocity interface) reads the encoders (q, dq) and gives the velocity command;
2. the servo amplifier (`servo.VelocityPI`) turns it into joint torques, saturated at the limits;
3. a gripper command whose latency has passed moves the fingers' position targets;
4. `mujoco.mj_step` integrates (semi-implicit Euler, `model`);
5. the ball is watched: it is *released* at the first step after the hand opened in which no pad
   touches it (its state then is kept), and it *touches down* at its first contact with the floor
   or the table after that (the contact point is kept). Before the open it is *held* (`holding`)
   while the fingers are closed on it: told to close, the pads no further apart than the ball's
   diameter and `PADS_ON_BALL_M`, its centre within the pads' half-extent of the seat (`BuiltModel.held_offset_m`); a ball that was held
   and is no longer, before the hand opened, *left the hand* (`BallEvents.lost_at`, seen at the
   end of the run it happened in), and the open that follows releases nothing. At touchdown the simulated operator covers
   the target and puts the landing LED there, off by N(0, placement_sigma^2) in x and y: on the
   real rig a person does this, and the rig measures the LED, never the truth.

Steps 1, 2 and 4 run compiled (`cycle.run_periods`), many periods per call: up to the next thing
Python does (a gripper command falling due, at most `MAX_PERIODS`), or up to the step in which
the watched event happened (the model's contact sensors say the ball left the pads, or touched a
surface), which Python then looks at as before; the ball's path (a point every 10 ms in flight)
is recorded in the loop, at the steps Python would record it. A run ending at an event may have
taken the host's reference for periods it did not reach: the host takes them back
(`VelocityLaw.commanded`).
The host is either a `VelocityLaw` (the arm driver, `devices.MujocoArm`: the velocity-mode law
v_c = clip(v_ref + K_p (q_ref - q)) with its reference given for all the periods of a run, so that
the law runs compiled) or any `HostController` called once per period from Python (tests, other
hosts). Both give the same commands; the first at the cost of MuJoCo's step.

The simulated operator also reloads: when the hand is told to close while the ball is not between
its pads, a ball is put on the hand's seat (moving with the hand) just before the fingers move,
and the landing LED is taken away and the target uncovered.

Thread-safety: one re-entrant lock around every public method; the host's controller is called
with it held (from whichever thread made the lab catch up).
"""

from __future__ import annotations

import math
import threading
from collections.abc import Callable

import mujoco
import numpy as np
from numpy.typing import ArrayLike, NDArray

from wiithrow.app.settings import Settings
from wiithrow.app.worlds.mujoco.arm_servo import power_on
from wiithrow.app.worlds.mujoco.ball_events import BallEvents
from wiithrow.app.worlds.mujoco.cycle import (
    POSE_COLUMNS,
    SERVO_POSITION,
    SERVO_TORQUE,
    WATCH_NOTHING,
    WATCH_RELEASE,
    WATCH_TOUCHDOWN,
    PathRecording,
    SetpointLaw,
    VelocityLaw,
    run_periods,
)
from wiithrow.app.worlds.mujoco.led_rows import rows_in_link1
from wiithrow.app.worlds.mujoco.mjcf_world import build_world
from wiithrow.app.worlds.mujoco.model import BuiltModel, link1_pose
from wiithrow.app.worlds.mujoco.servo import VelocityPI
from wiithrow.clock import Clock
from wiithrow.vision.wiimote.sim_reports import SourceRows

#: The host's controller: (t, q, dq) -> velocity command (rad/s), called every servo period.
HostController = Callable[[float, NDArray[np.float64], NDArray[np.float64]], NDArray[np.float64]]


#: The most servo periods one compiled run covers (the length of a host's reference buffer).
MAX_PERIODS = 100
#: Steps of poses kept (`cycle.POSE_COLUMNS`): a remote reporting up to this many steps (2 s) before
#: the physics' time sees the LEDs as they were then (`led_rows_in_link1`).
POSE_RING = 2048
#: More periods than any run covers ("no limit").
_UNLIMITED = 1 << 62

#: LEDs of the scene, by the names of the world's IR sources.
LEDS = ("marker", "target", "landing")
#: How often the ball's flight is recorded for drawing (s), and how long after touchdown.
PATH_PERIOD_S = 0.01
PATH_AFTER_TOUCHDOWN_S = 1.0
#: Below this height (m) a target stands on the floor: the table is put away.
FLOOR_TARGET_M = 0.01
#: The pads are on the ball while the gap between them is at most the ball's diameter plus this (m):
#: the fingers' positions sum to 0 when both touch a ball wherever it sits between them (one
#: finger's travel out is the other's in), below 0 as they squeeze it; closing on it they come from
#: twice the 30 mm stroke, and with the ball gone they close to -20 mm.
PADS_ON_BALL_M = 0.0005


#: `MujocoLab._leds`: (step, names, which were shown, the LEDs as rows).
_KeptLeds = tuple[int, tuple[str, ...], tuple[bool, ...], SourceRows]


class MujocoLab:
    """The physics of the MuJoCo world on `clock` (see the module docstring)."""

    def __init__(
        self, settings: Settings, clock: Clock, *, q0: ArrayLike | None = None, seed: int | None = None
    ) -> None:
        self.settings = settings
        self.clock = clock
        self.built: BuiltModel = build_world(settings)
        self.model = m = self.built.model
        self.data = mujoco.MjData(m)
        self.h = float(m.opt.timestep)
        self._lock = threading.RLock()
        # the operator's placement and the hand's jitter; the arm's tolerances come from settings.mujoco.seed
        self._rng = np.random.default_rng(np.random.SeedSequence([settings.mujoco.seed if seed is None else seed, 1]))
        b = self.built
        nominal = settings.load_arm()
        q = np.asarray(nominal.home if q0 is None else q0, dtype=float)
        self.data.qpos[b.joint_qpos] = q
        self.data.qpos[b.finger_qpos] = b.finger_open_qpos
        self.data.ctrl[b.finger_actuators] = b.finger_open_ctrl
        self._park_ball()
        mujoco.mj_forward(m, self.data)
        inertia = self._joint_inertia()
        mj = settings.mujoco
        self.servo = VelocityPI(inertia, b.dynamics.torque_limit_nm, 2 * math.pi * mj.velocity_bandwidth_hz, self.h)
        # powered on and settled: the integrals hold the arm against gravity and friction from the start
        gravity = self.data.qfrc_bias[b.joint_dof]
        self.servo.integral[:] = gravity / (self.servo.gain * self.servo.integral_rate)
        assert b.servo is not None
        self._servo_kind = b.servo.index  # what the arm's actuators take (`arm_servo`)
        # a position servo holds where the arm stands, a velocity servo holds still, until the host's
        # first command (the project's torque motors are driven by `servo` from the first period)
        self._hold_command = q.copy() if self._servo_kind == SERVO_POSITION else np.zeros(len(b.joint_dof))
        if self._servo_kind != SERVO_TORQUE:
            power_on(m, self.data, b.arm_ctrl, self._hold_command)
        self.t0 = float(clock.now())
        self.k = 0
        self._host: HostController | None = None  # called per period from Python
        self._law: VelocityLaw | None = None  # ... or run compiled
        self._setpoints = False  # the law gives the position servo's setpoints (`SetpointLaw`)
        self._v_command = self._hold_command.copy()  # the last command: a velocity, or a setpoint
        if self._servo_kind != SERVO_TORQUE:
            self.data.ctrl[b.arm_ctrl] = self._v_command
        self._no_reference = np.zeros((1, len(b.joint_dof)))  # (for a run without a VelocityLaw)
        # its velocity limit read-only, as a law's (`ArmLimits`) is: one compiled signature of `run_periods`
        self._no_limit = np.zeros(len(b.joint_dof))
        self._no_limit.flags.writeable = False
        self._ramp = np.arange(MAX_PERIODS, dtype=np.float64)  # the periods of a run, 0, 1, ...
        # the ball's path points a run recorded (`cycle.PathRecording`)
        self._path_times = np.empty(MAX_PERIODS)
        self._path_points = np.empty((MAX_PERIODS, 3))
        self._path_count = np.zeros(1, dtype=np.int64)
        # each step's pose (`cycle.POSE_COLUMNS`), row k % POSE_RING; this one's now
        self._poses = np.zeros((POSE_RING, POSE_COLUMNS))
        self._keep_pose()
        s, d = self.servo, self.data
        # what every run passes to the compiled loop (`cycle.run_periods`, from `model` on): the
        # MjData's arrays are views of its buffers, the servo's state is written in place
        self._fixed = (
            *(m._address, d._address, d.qpos, d.qvel, d.ctrl, d.sensordata),
            *(b.arm_qpos.start, b.arm_dof.start, b.arm_ctrl.start, self._v_command),
            *(s.gain, s.integral_rate, s.integral, s.torque_limit, s.period),
            *(b.pad_sensors, b.surface_sensors, s.counters),
            *(d.xpos, d.xmat, d.site_xpos, b.link1_body, b.sites["marker_led"], self._poses),
        )
        self._pending: list[tuple[float, str]] = []  # gripper commands (time they take effect, "open"/"closed")
        self.gripper_command = "open"
        self.gripper_delays: list[float] = []  # latency + jitter of every command, for tests
        self.lit = dict.fromkeys(LEDS, False)
        # the last `leds_in_link1`: (step, names, which were shown, the LEDs as rows); forgotten
        # when the scene changes between steps (`place_table`, `_load_ball`, `_place_landing_marker`)
        self._leds: _KeptLeds | None = None
        self._led_sites = {name: self.built.sites[f"{name}_led"] for name in LEDS}  # LED -> its site's id
        # link1's nominal pose at q = 0 (`model.link1_pose`) as floats: (R0's rows, p0), None: identity
        offset = self.built.link1_offset
        self._link1_offset: tuple[list[float], list[float], list[float], list[float]] | None = (
            None if offset is None else (*offset[0].tolist(), offset[1].tolist())
        )
        self._target_covered = False
        # the simulated operator covers the target while the hand's calibration LED is on: a
        # calibration wants one lit IR source (what an operator of the real rig is told to do)
        self._covered_for_marker = False
        self.ball_in_hand = False
        self._fingers_closed = False  # the last gripper command applied was "closed"
        self.events = BallEvents()
        self.throws = 0

    # -- time -------------------------------------------------------------------------------------

    @property
    def t(self) -> float:
        """The time of the last simulated step (s, the clock's)."""
        return self.t0 + self.k * self.h

    def advance(self) -> None:
        """Step the physics up to the clock's now."""
        with self._lock:
            n = math.floor((self.clock.now() - self.t) / self.h + 1e-9)
            while n > 0:
                n -= self._run(n)

    def _run(self, n: int) -> int:
        """Run up to `n` periods, at most up to the next one Python has to look at (module
        docstring); return how many ran."""
        b, d = self.built, self.data
        t = self.t
        while self._pending and self._pending[0][0] <= t + 1e-12:
            self._apply_gripper(self._pending.pop(0)[1])
        n = min(n, MAX_PERIODS, self._periods_to_pending())
        ev = self.events
        if ev.opened_at is None:
            watch = WATCH_NOTHING
        elif ev.released_at is None:
            watch = WATCH_RELEASE
        else:
            watch = WATCH_TOUCHDOWN if ev.touchdown_at is None else WATCH_NOTHING
        law, host = self._law, self._host
        if law is not None:
            # (a run may end at the watched event: the law takes back the periods that did not run)
            times = self.t0 + (self.k + self._ramp[:n]) * self.h
            if self._setpoints:  # rows of setpoints (`SetpointLaw`): the compiled loop reads them as q_ref
                q_ref = v_ref = law.setpoints(times)  # type: ignore[attr-defined]
                gain, v_limit = 0.0, self._no_limit
            else:
                q_ref, v_ref = law.references(times)
                gain, v_limit = law.position_gain, law.velocity_limit
        else:
            if host is not None:  # a controller called per period from Python
                n = 1
                self._v_command[:] = host(t, d.qpos[b.arm_qpos].copy(), d.qvel[b.arm_dof].copy())
            q_ref = v_ref = self._no_reference
            gain, v_limit = 0.0, self._no_limit
        done = run_periods(
            n,
            self._servo_kind,
            watch,
            law is not None,
            q_ref,
            v_ref,
            gain,
            v_limit,
            self._path_recording(),
            *self._fixed,
        )
        if law is not None:
            law.commanded(self._v_command, int(done))
        self.k += done
        for row in range(int(self._path_count[0])):
            ev.path_t.append(float(self._path_times[row]))
            ev.path.append(self._path_points[row].copy())
        self._watch_ball()
        return int(done)

    def _path_recording(self) -> PathRecording:
        """What the compiled loop needs to record the ball's path in flight (`cycle.PathRecording`:
        `_watch_ball`'s test, after the release's first point)."""
        ev = self.events
        record = ev.released_at is not None and bool(ev.path_t)
        last = ev.path_t[-1] if record else 0.0
        touchdown = math.inf if ev.touchdown_at is None else ev.touchdown_at
        return (
            record,
            self.t0,
            self.k,
            self.h,
            last,
            PATH_PERIOD_S - 1e-9,
            touchdown,
            PATH_AFTER_TOUCHDOWN_S,
            self.built.ball_qpos,
            self._path_times,
            self._path_points,
            self._path_count,
        )

    def _periods_to_pending(self) -> int:
        """Periods until the one at whose start the next gripper command takes effect."""
        if not self._pending:
            return _UNLIMITED
        due = self._pending[0][0]
        j = max(1, math.floor((due - self.t) / self.h) - 1)
        while due > self.t0 + (self.k + j) * self.h + 1e-12:  # the test `_run` applies
            j += 1
        return j

    def _joint_inertia(self) -> NDArray[np.float64]:
        M = np.zeros((self.model.nv, self.model.nv))
        mujoco.mj_fullM(self.model, self.data, M)
        return np.diag(M)[self.built.joint_dof].copy()

    # -- the arm (the servo's side of the PA-10's velocity interface) ------------------------------

    def attach_host(self, controller: HostController | VelocityLaw | SetpointLaw | None) -> None:
        """The host's controller gives the command of every servo period from now on (None: 0 rad/s,
        or a position servo's setpoint where the arm stands): a velocity, or a position servo's
        setpoint (`arm_servo`); a `VelocityLaw` or a `SetpointLaw` runs compiled."""
        with self._lock:
            self.advance()
            compiled = isinstance(controller, VelocityLaw | SetpointLaw)
            if compiled and isinstance(controller, SetpointLaw) != (self._servo_kind == SERVO_POSITION):
                raise ValueError(
                    "a position servo takes setpoints (a SetpointLaw), a torque or velocity servo velocities"
                )
            self._law = controller if compiled else None  # type: ignore[assignment]
            self._setpoints = isinstance(controller, SetpointLaw)
            self._host = None if compiled else controller  # type: ignore[assignment]
            if controller is None:
                b = self.built
                held = self.data.qpos[b.joint_qpos] if self._servo_kind == SERVO_POSITION else 0.0
                self._v_command[:] = held

    def read_arm(self) -> tuple[float, NDArray[np.float64], NDArray[np.float64]]:
        """(t, q, dq) of the arm's encoders now."""
        with self._lock:
            self.advance()
            b = self.built
            return self.t, self.data.qpos[b.joint_qpos].copy(), self.data.qvel[b.joint_dof].copy()

    # -- the hand ---------------------------------------------------------------------------------

    def command_gripper(self, command: str, at: float | None = None) -> tuple[float, str]:
        """ "open" or "closed", taking effect after the latency and its jitter (settings); `at`: as if
        commanded then (s, the clock's; past: now; `gripper_command` left to the caller). Its entry."""
        if command not in ("open", "closed"):
            raise ValueError(f"a gripper command is 'open' or 'closed', got {command!r}")
        with self._lock:
            self.advance()
            mj = self.settings.mujoco
            jitter = float(self._rng.normal(0.0, mj.release_jitter_s)) if mj.release_jitter_s > 0 else 0.0
            delay = max(0.0, mj.release_latency_s + jitter)
            self.gripper_delays.append(delay)
            if at is None:
                self.gripper_command = command
            entry = (max(self.t, self.t if at is None else float(at)) + delay, command)
            self._pending.append(entry)
            self._pending.sort(key=lambda item: item[0])
            return entry

    def withdraw_gripper(self, entry: tuple[float, str], before: float) -> bool:
        """Take back a command of `command_gripper` if the physics has not reached `before`."""
        with self._lock:
            self.advance()
            if self.t < before - 1e-12 and entry in self._pending:
                self._pending.remove(entry)
                return True
            return False

    def _apply_gripper(self, command: str) -> None:
        b, d = self.built, self.data
        ev = self.events
        if command == "open":
            self._let_go()
            self._watch_grip()
            self._fingers_closed = False
            d.ctrl[b.finger_actuators] = b.finger_open_ctrl
            if self.ball_in_hand and ev.opened_at is None:
                if ev.lost_at is None:
                    ev.opened_at = self.t
                else:  # it had left the hand: this open releases nothing
                    ev.lost_open_at = self.t
                    self.ball_in_hand = False
            return
        if not self._ball_between_pads():
            self._load_ball()
        self._fingers_closed = True
        d.ctrl[b.finger_actuators] = b.finger_closed_ctrl  # inside the ball: the force limit sets the grip

    def finger_opening(self) -> float:
        """How far the fingers are open: 0 on the ball (or closed on nothing), 1 fully open."""
        with self._lock:
            self.advance()
            b = self.built
            x = (self.data.qpos[b.finger_qpos] - b.finger_ball_qpos) / (b.finger_open_qpos - b.finger_ball_qpos)
            return min(1.0, max(0.0, float(np.mean(x))))

    def holding(self) -> bool:
        """True while the fingers are closed on the ball (module docstring, step 5); then a simulated
        operator who held the ball in a slow hand lets go of it (`BuiltModel.operator_hold`)."""
        with self._lock:
            self.advance()
            held = self._held()
            if held:
                self._let_go()
                if self.events.held_in_hand is None and self.ball_in_hand:
                    self.events.held_in_hand = self._ball_in_hand()
            return held

    def _held(self) -> bool:
        b = self.built
        if not self._fingers_closed:
            return False
        # each finger's travel out from where its pad meets the ball (m), summed: 0 with both on it
        apart = (self.data.qpos[b.finger_qpos] - b.finger_ball_qpos) * np.sign(b.finger_open_qpos - b.finger_ball_qpos)
        if float(np.sum(apart)) > PADS_ON_BALL_M:
            return False
        seat = self.data.site_xpos[b.sites["ball_seat"]]
        return bool(np.linalg.norm(self.ball_position_now() - seat) < b.held_offset_m)

    def _watch_grip(self) -> None:
        """Before the open: the ball held once, then no longer, left the hand (`BallEvents.lost_at`)."""
        ev = self.events
        if not self.ball_in_hand or ev.opened_at is not None or ev.lost_at is not None:
            return
        if self._held():
            ev.gripped = True
        elif ev.gripped:
            ev.lost_at = self.t

    def set_grip_force(self, force_n: float) -> None:
        """The fingers' force limit from now on (N): a grip that weakens (a worn pad, a drop in the
        hand's air pressure), as a test makes one too weak for the wind-up's acceleration."""
        if not (math.isfinite(force_n) and force_n >= 0.0):
            raise ValueError(f"a grip force is a finite number >= 0 N, got {force_n}")
        with self._lock:
            self.advance()
            self.model.actuator_forcerange[self.built.finger_actuators] = [-force_n, force_n]

    def _ball_in_hand(self) -> NDArray[np.float64]:
        """The ball's centre in the ball seat's frame now (m)."""
        d, site = self.data, self.built.sites["ball_seat"]
        return d.site_xmat[site].reshape(3, 3).T @ (self.ball_position_now() - d.site_xpos[site])

    def _let_go(self) -> None:
        """The simulated operator takes their hand off the ball (`BuiltModel.operator_hold`)."""
        if self.built.operator_hold >= 0:
            self.data.eq_active[self.built.operator_hold] = False

    # -- the ball ---------------------------------------------------------------------------------

    def _park_ball(self) -> None:
        """Put the ball away (on the floor, far from everything) at rest."""
        b, d = self.built, self.data
        r = self.settings.ball.radius_m
        d.qpos[b.ball_qpos : b.ball_qpos + 7] = [-2.0, -2.0, r, 1.0, 0.0, 0.0, 0.0]
        d.qvel[b.ball_dof : b.ball_dof + 6] = 0.0

    def _ball_between_pads(self) -> bool:
        seat = self.data.site_xpos[self.built.sites["ball_seat"]]
        return bool(np.linalg.norm(self.ball_position_now() - seat) < 0.5 * self.settings.ball.radius_m)

    def _load_ball(self) -> None:
        """The simulated operator puts a ball on the hand's seat, moving with the hand; takes the
        landing LED away and uncovers the target."""
        b, d, m = self.built, self.data, self.model
        site = b.sites["ball_seat"]
        self._leds = None
        d.qpos[b.ball_qpos : b.ball_qpos + 3] = d.site_xpos[site]
        d.qpos[b.ball_qpos + 3 : b.ball_qpos + 7] = [1.0, 0.0, 0.0, 0.0]
        if b.operator_hold >= 0:  # held on the seat, turned as it, until both pads touch it
            mujoco.mju_mat2Quat(d.qpos[b.ball_qpos + 3 : b.ball_qpos + 7], d.site_xmat[site])
            d.eq_active[b.operator_hold] = True
        vel = np.zeros(6)
        mujoco.mj_objectVelocity(m, d, mujoco.mjtObj.mjOBJ_SITE, site, vel, 0)
        d.qvel[b.ball_dof : b.ball_dof + 3] = vel[3:]
        d.qvel[b.ball_dof + 3 : b.ball_dof + 6] = 0.0
        mujoco.mj_forward(m, d)
        self.ball_in_hand = True
        self.events = BallEvents()
        self.lit["landing"] = False
        self._target_covered = False

    def ball_position_now(self) -> NDArray[np.float64]:
        b = self.built
        return self.data.qpos[b.ball_qpos : b.ball_qpos + 3].copy()

    def ball_position(self) -> NDArray[np.float64]:
        """The ball's centre now (m, base)."""
        with self._lock:
            self.advance()
            return self.ball_position_now()

    def _pad_contacts(self) -> list[int]:
        b, d = self.built, self.data
        out = []
        for i in range(d.ncon):
            c = d.contact[i]
            pair = {int(c.geom1), int(c.geom2)}
            if b.ball_geom in pair and pair & b.pad_geoms:
                out.append(i)
        return out

    def _surface_contact(self) -> NDArray[np.float64] | None:
        b, d = self.built, self.data
        for i in range(d.ncon):
            c = d.contact[i]
            pair = {int(c.geom1), int(c.geom2)}
            if b.ball_geom in pair and pair & b.surface_geoms:
                return np.array(c.pos, dtype=float)
        return None

    def _watch_ball(self) -> None:
        ev = self.events
        if ev.opened_at is None:
            self._watch_grip()
            return
        t = self.t
        if ev.released_at is None:
            if self._pad_contacts():
                return
            b, d = self.built, self.data
            ev.released_at = t
            ev.release_position = self.ball_position_now()
            ev.release_velocity = d.qvel[b.ball_dof : b.ball_dof + 3].copy()
            # a free joint's angular velocity is in the body frame: turn it into base
            xmat = d.xmat[b.ball_body].reshape(3, 3)
            ev.release_spin = xmat @ d.qvel[b.ball_dof + 3 : b.ball_dof + 6]
            ev.release_q = d.qpos[b.joint_qpos].copy()
            ev.release_dq = d.qvel[b.joint_dof].copy()
            ev.release_in_hand = self._ball_in_hand()
            self.ball_in_hand = False
            self.throws += 1
        due = not ev.path_t or t - ev.path_t[-1] >= PATH_PERIOD_S - 1e-9
        if due and (ev.touchdown_at is None or t - ev.touchdown_at <= PATH_AFTER_TOUCHDOWN_S):
            ev.path_t.append(t)
            ev.path.append(self.ball_position_now())
        if ev.touchdown_at is None:
            point = self._surface_contact()
            if point is not None:
                ev.touchdown_at = t
                ev.touchdown = point
                self._place_landing_marker(point)

    def _place_landing_marker(self, point: NDArray[np.float64]) -> None:
        """The simulated operator covers the target and puts the landing LED at the touchdown."""
        sigma = self.settings.mujoco.placement_sigma_m
        self._leds = None
        error = self._rng.normal(0.0, sigma, 2) if sigma > 0 else np.zeros(2)
        marker = np.array([point[0] + error[0], point[1] + error[1], point[2]])
        self.events.marker = marker
        self.model.site_pos[self.built.sites["landing_led"]] = marker
        self.lit["landing"] = True
        self._target_covered = True

    # -- LEDs and the target ------------------------------------------------------------------------

    def set_led(self, name: str, on: bool) -> None:
        if name not in LEDS:
            raise ValueError(f"the MuJoCo world has the LEDs {LEDS}, not {name!r}")
        with self._lock:
            self.advance()
            self.lit[name] = bool(on)
            if name == "target" and on:
                self._target_covered = False
            if name == "marker":
                self._covered_for_marker = bool(on)

    def place_target(self, position_base: ArrayLike) -> None:
        """Put the target LED at `position_base` (m) on a table whose top is its height (no table
        for a target on the floor)."""
        p = np.asarray(position_base, dtype=float).reshape(3)
        with self._lock:
            self.model.site_pos[self.built.sites["target_led"]] = p
            self.place_table(p)

    def place_table(self, top_base: ArrayLike) -> None:
        """Put the table's top centre at `top_base` (m); a point on the floor takes the table away."""
        p = np.asarray(top_base, dtype=float).reshape(3)
        with self._lock:
            self.advance()
            m, b = self.model, self.built
            self._leds = None
            if p[2] > b.floor_z + FLOOR_TARGET_M:
                self.data.mocap_pos[b.table_mocap] = [p[0], p[1], p[2] - b.table_half[2]]
            else:
                self.data.mocap_pos[b.table_mocap] = [3.0, 3.0, -b.table_half[2]]
            mujoco.mj_forward(m, self.data)

    def target_position(self) -> NDArray[np.float64]:
        with self._lock:
            return self.model.site_pos[self.built.sites["target_led"]].copy()

    def led_positions(self) -> dict[str, NDArray[np.float64]]:
        """Where each LED is now (m, base), NaN while it is off (the target also while covered)."""
        with self._lock:
            self.advance()
            out = {}
            for name in LEDS:
                on = self._shows(name)
                out[name] = self.data.site_xpos[self.built.sites[f"{name}_led"]].copy() if on else np.full(3, np.nan)
            return out

    def link1_pose(self) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """(R, o): the true link1's orientation and origin in base now (the rig is mounted there)."""
        with self._lock:
            self.advance()
            return link1_pose(self.built, self.data)

    def leds_in_link1(self, names: tuple[str, ...], t: float | None = None) -> NDArray[np.float64]:
        """The LEDs `names` (len, 3) in the true link1 frame, NaN for those off or unknown: each
        lit LED at p (base) is R^T (p - o), (R, o) the link1 pose (`link1_pose`), at time `t` (the
        last step at or before it; None: now). A new array."""
        return np.array(self._leds_at(names, t), dtype=float).reshape(len(names), 3)

    def led_rows_in_link1(self, names: tuple[str, ...], t: float | None = None) -> SourceRows:
        """`leds_in_link1` as rows of plain floats, shared (a tuple: nobody can change it): what
        the simulated remotes see, 200 times per simulated second, and observe in plain floats
        (`WiimoteCamera.observe_few`), without an array copied and converted per report."""
        return self._leds_at(names, t)

    def _leds_at(self, names: tuple[str, ...], t: float | None) -> SourceRows:
        """The LEDs `names` at time `t` as rows (see `leds_in_link1`), computed once per physics
        step for the remotes that read then: no dictionaries, and a change of the scene at that
        step (`_leds` forgotten) or of what is shown recomputes them.

        The physics steps up to now, as for any reader; a report's time it has passed (a report that
        fell due inside a long run: a real-time world catching up after its host was not scheduled,
        a wait that moved a simulated clock 10 ms at a time) takes link1's pose
        and the hand's LED from the ring of the steps' poses (`cycle.POSE_COLUMNS`), so that the
        report shows them where they were at its time, as a real camera's frame does; the target
        and landing LEDs stand still (they are where they are now), and what is lit is what is lit
        now. Older than the ring (`POSE_RING` steps): the pose now."""
        with self._lock:
            self.advance()  # to now, in as few runs as before (a remote's t is never later)
            step = self.k if t is None else min(self.k, self.k + math.floor((t - self.t) / self.h + 1e-9))
            # `_shows` of each LED of the lab (the others, a world's beacons, are not shown),
            # spelled out: one dictionary lookup per name and no call, 200 times a second
            lit, covered = self.lit, self._target_covered or self._covered_for_marker
            shown = tuple([lit.get(name, False) and not (covered and name == "target") for name in names])
            cached = self._leds
            if cached is not None and cached[0] == step and cached[1] == names and cached[2] == shown:
                return cached[3]
            kept = step if self.k - POSE_RING < step < self.k else None
            rows = self._leds_in_link1_floats(names, shown, kept)
            self._leds = (step, names, shown, rows)
            return rows

    def _keep_pose(self) -> None:
        """This step's pose into its row of the ring (`cycle.POSE_COLUMNS`; the compiled runs keep theirs)."""
        d, b = self.data, self.built
        row = self._poses[self.k % POSE_RING]
        row[:3] = d.xpos[b.link1_body]
        row[3:12] = d.xmat[b.link1_body]
        row[12:] = d.site_xpos[b.sites["marker_led"]]

    def _leds_in_link1_floats(
        self, names: tuple[str, ...], shown: tuple[bool, ...], kept_step: int | None = None
    ) -> SourceRows:
        """The shown LEDs in link1 (`led_rows.rows_in_link1`), from the pose now or at the step
        `kept_step` from the ring (`_leds_at`)."""
        d, i = self.data, self.built.link1_body
        if kept_step is None:
            pose = (*d.xpos[i].tolist(), *d.xmat[i].tolist())
        else:
            pose = tuple(self._poses[kept_step % POSE_RING].tolist())
        return rows_in_link1(pose, self._link1_offset, d.site_xpos, self._led_sites, names, shown)

    def _shows(self, name: str) -> bool:
        """LED `name` is lit and not covered (the target is covered under the landing LED, and
        while the hand's LED is on)."""
        covered = name == "target" and (self._target_covered or self._covered_for_marker)
        return self.lit[name] and not covered

    # -- the simulated operator's side ------------------------------------------------------------

    def place_landing_marker(self, point: NDArray[np.float64]) -> None:
        """The operator covers the target and puts the landing LED at `point` (m, base), off by
        their placement error, as after a touchdown (*Measure landing* asks them to)."""
        with self._lock:
            self.advance()
            self._place_landing_marker(np.asarray(point, dtype=float).reshape(3))

    def landing_measured(self) -> None:
        """The landing marker was measured: the operator takes it away, uncovers the target and puts
        the table back under it (a training target's surface, `place_table`, stood elsewhere; the next
        throw at the target would come down on it)."""
        with self._lock:
            self.advance()
            self.lit["landing"] = False
            self._target_covered = False
            self.place_table(self.model.site_pos[self.built.sites["target_led"]])
