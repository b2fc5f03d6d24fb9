"""The MuJoCo world's devices, each behind the interface its real counterpart implements:

* `MujocoServo`: the servo's interface (`wiithrow.robot.host_arm.ServoInterface`): the lab's
  amplifier or the servo in its model (`arm_servo`), fed a velocity or a setpoint every period;
* `MujocoArm`: the arm driver over a torque or velocity servo, the host's `VelocityModeArm`, plus `set_marker_led`
  (the hand's calibration LED, switched through the arm as a real driver may). Its per-period
  controller runs compiled in the lab (`cycle.VelocityLaw`): the same law on the same reference,
  which the arm hands over for many periods at once (`references`: its interpolator stepped to
  each period's time, exactly as the per-period controller steps it, vectorised; the periods a
  run did not reach are taken back in `commanded`);
* `MujocoPositionArm`: the arm driver over a position servo (a joint PD, `arm_servo`), the host's
  `PositionModeArm`, its setpoints compiled the same way (`cycle.SetpointLaw`: the reference plus
  the feed-forward the settings name, `mujoco.feedforward`, for many periods at once);
* `MujocoGripper`: the hand (`wiithrow.robot.gripper.Gripper`): open and close after the lab's
  latency, its opening from the fingers' joints, holding while both pads touch the ball. It
  schedules opens (`ScheduledOpen`): `open_at(t)` is an open commanded at `t` on the lab's clock,
  in the lab's pending commands, so the physics opens the fingers at the step its latency ends
  however late the host gets round to reading the lab (as a controller's IO synchronised to the
  trajectory does); `cancel_open()` withdraws it while the physics has not reached the
  command's time. It says when it carried out its last open (`ReportsOpenTime`): a scheduled
  open's command time once the physics reached it, an `open()`'s time on the lab's clock.

Nothing above these classes touches MuJoCo: the session, the calibration, the throw and the
dashboard drive them as they would drive hardware.
"""

from __future__ import annotations

import threading

import numpy as np
from numpy.typing import NDArray

from wiithrow.app.worlds.mujoco.lab import MujocoLab
from wiithrow.clock import Clock, SimClock
from wiithrow.robot import ArmModel, JointState
from wiithrow.robot.errors import RobotError
from wiithrow.robot.feedforward import PDFeedForward
from wiithrow.robot.gripper import GripperCommand, GripperState
from wiithrow.robot.position_mode import PositionModeArm
from wiithrow.robot.simulated import SimulatedArm
from wiithrow.robot.simulated_snapshot import SimulatedArmSnapshot
from wiithrow.robot.velocity_mode import VelocityController, VelocityModeArm


class MujocoServo:
    """The lab's servo amplifier as a `VelocityInterface`."""

    def __init__(self, lab: MujocoLab) -> None:
        self.lab = lab

    def read(self) -> JointState:
        t, q, dq = self.lab.read_arm()
        return JointState(t, q, dq)

    def attach(self, controller: VelocityController | None) -> None:
        self.lab.attach_host(controller)


class _CompiledReference:
    """What the MuJoCo arm drivers share (`HostArm`s): the interpolator's reference handed to the
    lab's compiled runs many periods at once, and taken back for the periods a run did not reach."""

    interpolator: SimulatedArm
    last_command: NDArray[np.float64]
    _lock: threading.RLock
    _ref_clock: SimClock

    def _init_reference(self, nq: int) -> None:
        self._rest = False  # the interpolator was found at rest at _rest_qv (`_resting_at`)
        self._rest_qv = (np.empty((1, nq)), np.empty((1, nq)))
        # what `references` took and `commanded` may give back: (the interpolator's snapshot
        # before, the periods' times, its commands_started after)
        self._taken: tuple[SimulatedArmSnapshot, NDArray[np.float64], int] | None = None

    def references(self, times: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """The interpolator's (q, dq) at each of `times` (as `HostArm._reference_at` takes them:
        its clock moved to the period's time first), all at once (`SimulatedArm.ideal_path`); one
        row while it rests (then it stays put). The interpolator's clock moves on in `commanded`,
        to the last period that ran."""
        with self._lock:
            interpolator = self.interpolator
            self._taken = None
            if self._resting_at(interpolator):
                self._move_clock(float(times[-1]))
                return self._rest_qv
            before = interpolator.snapshot()
            q_ref, v_ref = interpolator.ideal_path(times)  # new arrays, only read by the run: no copy
            if not interpolator.is_moving():  # at rest from now on: no command comes during a run
                self._rest = True
                self._rest_qv[0][0], self._rest_qv[1][0] = q_ref[-1], v_ref[-1]
            self._taken = (before, times.copy(), interpolator.commands_started)
            return q_ref, v_ref

    def _resting_at(self, interpolator: SimulatedArm) -> bool:
        """The interpolator rests where `_rest_qv` says: it was found at rest, and has
        had no command since (a command, even one to where it is, makes it a move or a stop; it
        steps only when asked for references, so a command cannot have come and gone unseen)."""
        if self._rest and interpolator.command_kind == "":
            return True
        self._rest = False
        return False

    def commanded(self, v_command: NDArray[np.float64], periods_run: int) -> None:
        """Keep the last command; take back the reference of the periods that did not run (the
        run ended at a watched event): the interpolator is put back and stepped again to the
        last period that ran, unless a command came meanwhile (then it starts from where the
        reference got, as it would have before). Its clock moves to that period."""
        with self._lock:
            self.last_command = v_command.copy()
            taken, self._taken = self._taken, None
            if taken is None:
                return
            before, times, commands = taken
            interpolator = self.interpolator
            if periods_run < len(times) and interpolator.commands_started == commands:
                interpolator.restore(before)
                interpolator.ideal_path(times[:periods_run])
                self._rest = False  # (it may have come to rest only in a period that did not run)
            self._move_clock(float(times[max(periods_run, 1) - 1]))

    def _move_clock(self, t: float) -> None:
        """The interpolator's clock to `t` (never back)."""
        lag = t - self._ref_clock.now()
        if lag > 0:
            self._ref_clock.advance(lag)


class MujocoArm(_CompiledReference, VelocityModeArm):
    """The arm driver of the MuJoCo world over a velocity servo (module docstring); a `cycle.VelocityLaw`."""

    def __init__(self, model: ArmModel, clock: Clock, lab: MujocoLab) -> None:
        super().__init__(model, clock, MujocoServo(lab), position_gain=lab.settings.mujoco.position_gain_per_s)
        self.lab = lab
        self.velocity_limit = self.limits.velocity
        self._init_reference(model.nq)
        lab.attach_host(self)  # in place of the per-period controller `VelocityModeArm` attached

    def set_marker_led(self, on: bool) -> None:
        """Switch the hand's calibration LED."""
        self.lab.set_led("marker", on)


class MujocoPositionArm(_CompiledReference, PositionModeArm):
    """The arm driver of the MuJoCo world over a position servo (module docstring); a
    `cycle.SetpointLaw`: the setpoints of many periods at once, each the reference's plus
    `feedforward`'s correction for its (q, v, a), a the difference of consecutive periods' v."""

    def __init__(self, model: ArmModel, clock: Clock, lab: MujocoLab, feedforward: PDFeedForward | None) -> None:
        super().__init__(model, clock, MujocoServo(lab), feedforward=feedforward)
        self.lab = lab
        self._init_reference(model.nq)
        self._period = lab.h
        self._v_before = np.zeros(model.nq)  # v_ref of the last period that ran
        self._v_rows: NDArray[np.float64] | None = None  # v_ref of the periods of the last `setpoints`
        self._rest_setpoint: tuple[NDArray[np.float64], NDArray[np.float64]] | None = None  # (q_ref, q_set) at rest
        lab.attach_host(self)

    def setpoints(self, times: NDArray[np.float64]) -> NDArray[np.float64]:
        """The setpoints (rad) of the periods at `times` (`cycle.SetpointLaw`)."""
        q_ref, v_ref = self.references(times)
        ff = self.feedforward
        if q_ref is self._rest_qv[0]:  # at rest: one row, kept while the rest lasts
            self._v_rows = None
            self._v_before = np.zeros_like(self._v_before)
            kept = self._rest_setpoint
            if kept is None or not np.array_equal(kept[0], q_ref[0]):
                zero = np.zeros_like(q_ref)
                kept = (q_ref[0].copy(), q_ref.copy() if ff is None else ff.setpoints(q_ref, zero, zero))
                self._rest_setpoint = kept
            return kept[1]
        self._v_rows = v_ref
        if ff is None:
            return q_ref
        a_ref = np.diff(v_ref, axis=0, prepend=self._v_before[None, :]) / self._period
        return ff.setpoints(q_ref, v_ref, a_ref)

    def commanded(self, v_command: NDArray[np.float64], periods_run: int) -> None:
        """As `_CompiledReference.commanded`; the last period's v_ref is kept for the next difference."""
        if self._v_rows is not None and periods_run > 0:
            self._v_before = self._v_rows[min(periods_run, len(self._v_rows)) - 1].copy()
        super().commanded(v_command, periods_run)

    def set_marker_led(self, on: bool) -> None:
        """Switch the hand's calibration LED."""
        self.lab.set_led("marker", on)


class MujocoGripper:
    """The hand of the MuJoCo world (module docstring)."""

    def __init__(self, lab: MujocoLab) -> None:
        self.lab = lab
        self._scheduled: tuple[float, tuple[float, str]] | None = None  # (its time, the lab's entry)
        self._opened: float | None = None  # when the last open was carried out, the scheduled one aside
        self._scheduled_open = float("nan")  # when the scheduled open is carried out (the lab's clock)

    def open(self) -> None:
        self.cancel_open()
        entry = self.lab.command_gripper("open")
        self._opened = entry[0] - self.lab.gripper_delays[-1]  # (the entry's time is the command's + its delay)

    def close(self) -> None:
        self.cancel_open()
        self._opened = None
        self.lab.command_gripper("closed")

    def open_at(self, t: float) -> None:
        """Open at `t` on the lab's clock (the jaws part the lab's latency later)."""
        if not np.isfinite(t):
            raise RobotError(f"a scheduled open needs a finite time, got {t}")
        self.cancel_open()
        at = float(t)
        entry = self.lab.command_gripper("open", at=at)
        self._scheduled = (at, entry)
        self._scheduled_open = entry[0] - self.lab.gripper_delays[-1]  # `t`, or the lab's now if `t` has passed

    def cancel_open(self) -> bool:
        scheduled, self._scheduled = self._scheduled, None
        if scheduled is None:
            return False
        if self.lab.withdraw_gripper(scheduled[1], before=scheduled[0]):
            return True
        self.lab.gripper_command = "open"  # its time came: it was the last command
        self._opened = self._scheduled_open
        return False

    def last_open_time(self) -> float | None:
        if self._scheduled is not None:
            self.lab.advance()
            carried = self._scheduled_open
            return carried if self.lab.t >= carried - 1e-12 else None
        return self._opened

    def state(self) -> GripperState:
        lab = self.lab
        opening = lab.finger_opening()
        scheduled = self._scheduled
        opened = lab.gripper_command == "open" or (scheduled is not None and lab.t >= scheduled[0] - 1e-12)
        command: GripperCommand = "open" if opened else "closed"
        return GripperState(lab.t, command, opening, lab.holding())

    def ball_position(self) -> np.ndarray:
        """Where the ball is (m, base): a simulated hand can say (the dashboard draws it)."""
        return self.lab.ball_position()

    def place_surface(self, point_base: np.ndarray) -> None:
        """The world's simulated operator puts the table's top at `point_base` (m; on the floor: no
        table), as a lab puts a surface under a training target (`HardwareWorld.set_surface`)."""
        self.lab.place_table(point_base)

    def landing_measured(self) -> None:
        """Tell the world's simulated operator that the landing marker was measured (they take it
        away and uncover the target), as `HardwareWorld` does after *Measure landing*."""
        self.lab.landing_measured()
