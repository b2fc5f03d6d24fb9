"""The paper's robot-driven calibration: the hand carries an IR LED through known positions.

Owns the procedure, for any arm that implements `robot.Arm` (with its `ArmModel`), any
`MarkerSource` (simulated or real remotes) and any clock; nothing here knows it is simulated:

    for each pose of a `PosePlan` (marker positions in link1, `wiithrow.app.calibration.poses`):
        IK for the marker at that position (joint 1 locked where it is, the LED turned towards
            the rig), move there (`arm.command_position`: a Ruckig move),
        keep reading the remotes until the arm is idle, then `settle_s` longer,
        average `frames` frames per camera taken after the settle time (the LED is the only lit
            source: each usable frame has exactly one dot),
        ground truth: the marker's position by forward kinematics of the MEASURED joint state at
            every frame time, averaged, in link1:  p_link1 = R_1^T (p_base - o_1),
        a pose that a camera does not see (fewer than half the frames with one dot) or that IK
            cannot reach is skipped, said so, and replaced by the nearest unused candidate;
    identify the arm's kinematic errors with the cameras (`wiithrow.app.calibration.kinematic`, the
        default `kinematics="identified"`: the FK's points are corrected, and the fit below uses
        them; `"nominal"` takes the nominal FK as exact, the paper's procedure),
    fit every camera (`wiithrow.app.calibration.points.calibrate_rig`), cross-validate (leave-one-out 3D error),
    save the calibration atomically with its meta (arm, poses, method, kinematic corrections).

Calibrating in `link1` keeps the calibration valid at every joint-1 angle: the rig turns with it.

Time: `wiithrow.app.rig.waiting.pump` sleeps on the clock in steps of `poll_step_s` and reads the remotes after each, so
with a `SimClock` the whole world runs faster than real time and with the system clock it keeps
up with the remotes. Progress goes to a tqdm bar on a terminal (`wiithrow.app.progress`) and to an
optional `progress(done, total, message)` callback; `cancel` (a `threading.Event` or a callable
returning True) stops the arm and raises `CalibrationCancelled` at the next poll.
"""

from __future__ import annotations

import os
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from wiithrow.app.calibration.kinematic import KINEMATICS, Kinematics, identify_kinematics
from wiithrow.app.calibration.points import calibrate_rig
from wiithrow.app.calibration.poses import Design, PoseCheck, PosePlan, rig_center, select_poses
from wiithrow.app.errors import AppError
from wiithrow.app.progress import progress_bar
from wiithrow.app.rig.source import MarkerSource
from wiithrow.app.rig.waiting import Cancel, Cancelled, is_cancelled, pump, wait_while_moving
from wiithrow.app.worlds import RigWorld, nominal_cameras
from wiithrow.clock import Clock
from wiithrow.robot import Arm, ArmModel, RobotError, solve_position
from wiithrow.vision import StereoCalibration
from wiithrow.vision.camera import WiimoteCamera
from wiithrow.vision.crossval import LeaveOneOut
from wiithrow.vision.dlt import Method

Progress = Callable[[int, int, str], None]

#: Poses of a robot calibration unless asked otherwise: with the arm's kinematics identified too
#: (`kinematic`), 60 poses bring the MuJoCo rig's 3D error over the throwing area to 1.41-1.61x the
#: true cameras' over five seeds (30 poses: 1.41-1.65x; 90: no better than 60), in about 70 s of
#: the arm's time (docs/calibration.md, "The arm's kinematics").
DEFAULT_POSES = 60

#: Fewer poses than this calibrate with the nominal kinematics: the joint fit of the cameras (22
#: unknowns for two) and about 15 kinematic corrections needs several times as many equations.
MIN_POSES_IDENTIFIED = 20


class CalibrationCancelled(AppError):
    """The operator stopped the calibration; the arm was stopped and nothing was saved."""


# --------------------------------------------------------------------------------------------
# Measuring poses


@dataclass(frozen=True)
class SkippedPose:
    """A pose that was not used: where it was (link1) and why."""

    target: NDArray[np.float64]
    reason: str


@dataclass(frozen=True)
class PoseData:
    """What the robot measured: `positions` (N, 3) marker positions in link1 (FK of the measured
    joints), `image` (C, N, 2) mean pixels, `pixel_std` (C, N, 2) their spread over the frames,
    `q` (N, nq) mean measured joints, `targets` (N, 3) the positions asked for, `skipped` poses,
    `duration_s` on the clock."""

    positions: NDArray[np.float64]
    image: NDArray[np.float64]
    pixel_std: NDArray[np.float64]
    q: NDArray[np.float64]
    targets: NDArray[np.float64]
    skipped: list[SkippedPose]
    duration_s: float

    def __len__(self) -> int:
        return int(self.positions.shape[0])


class _Pose:
    """Where the marker must go and how: target (link1) and a configuration known to reach it."""

    def __init__(self, target: NDArray[np.float64], hint: NDArray[np.float64]) -> None:
        self.target, self.hint = target, hint


class PoseMeasurer:
    """Drives the arm through poses and measures each (see the module docstring)."""

    def __init__(
        self,
        arm: Arm,
        arm_model: ArmModel,
        rig: MarkerSource,
        clock: Clock,
        cameras: Sequence[WiimoteCamera],
        *,
        frames: int = 10,
        settle_s: float = 0.3,
        poll_step_s: float = 0.01,
        move_timeout_s: float = 30.0,
        max_led_angle_deg: float = 60.0,
        cancel: Cancel = None,
        rng: np.random.Generator | None = None,
    ) -> None:
        if frames < 1:
            raise AppError(f"frames per pose must be at least 1, got {frames}")
        if frames > 100:
            raise AppError(f"at most 100 frames per pose are kept by the rig stream, got {frames}")
        self.arm, self.model, self.rig, self.clock = arm, arm_model, rig, clock
        self.cameras = list(cameras)
        self.frames, self.settle_s, self.step = frames, settle_s, poll_step_s
        self.move_timeout_s = move_timeout_s
        self.cancel = cancel
        self.rng = rng if rng is not None else np.random.default_rng(0)
        self.check = PoseCheck(arm_model, self.cameras, margin_px=-np.inf, max_led_angle_deg=max_led_angle_deg)
        self.rig_center = rig_center(self.cameras)
        self._samples: list[tuple[float, NDArray[np.float64]]] = []

    # -- frames ---------------------------------------------------------------------------------

    def link1(self, q: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """(R_1, o_1): placement of link1 in base at q."""
        T = self.model.frame_placement(q, "link1")
        return T[:3, :3], T[:3, 3]

    def marker_link1(self, q: NDArray[np.float64]) -> NDArray[np.float64]:
        """The marker's position in link1 at q:  p_link1 = R_1^T (p_base - o_1)."""
        return self.model.to_frame(self.model.frame_position(q, "marker"), q, "link1")

    # -- one pose -------------------------------------------------------------------------------

    def solve(self, pose: _Pose) -> NDArray[np.float64]:
        """Joint goal for the pose: IK from the current joints (short moves), joint 1 locked, the LED
        facing the rig; the plan's configuration (joint 1 where it is) if that fails the checks."""
        q_now = self.arm.state().q
        R1, _ = self.link1(q_now)
        target_base = self.model.from_frame(pose.target, q_now, "link1")
        face = R1 @ (self.rig_center - pose.target)
        try:
            q = solve_position(
                self.model,
                "marker",
                target_base,
                q_now,
                locked_joints=(0,),
                face_direction=face,
                restarts=4,
                rng=self.rng,
            )
            if self.check(q) is not None:
                return q
        except RobotError:
            pass
        hint = pose.hint.copy()
        hint[0] = q_now[0]
        if np.linalg.norm(self.marker_link1(hint) - pose.target) > 1e-3 or self.check(hint) is None:
            raise RobotError(f"no acceptable configuration puts the marker at {np.round(pose.target, 3)} m (link1)")
        return hint

    def move(self, q: NDArray[np.float64]) -> None:
        """Command the move and read the remotes until the arm is idle, then `settle_s` longer."""
        self.arm.command_position(q)
        if not wait_while_moving(
            self.arm, self.clock, self.rig, timeout_s=self.move_timeout_s, step_s=self.step, cancel=self.cancel
        ):
            self.arm.stop()
            raise AppError(
                f"the arm did not reach its calibration pose within {self.move_timeout_s:.0f} s; "
                "check the arm (and its driver) and run the calibration again"
            )
        pump(self.clock, self.rig, self.settle_s, step_s=self.step, cancel=self.cancel)

    def _record_state(self) -> None:
        s = self.arm.state()
        self._samples.append((s.t, s.q.copy()))

    def measure(self) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64], NDArray[np.float64], str]:
        """Average `frames` frames per camera taken from now on, and the marker's FK position over
        the same time. Returns (position link1, pixels (C, 2), pixel std (C, 2), mean q, problem):
        `problem` is '' when every camera saw exactly one dot in at least half the frames."""
        t0 = self.clock.now()
        self._samples = []
        self._record_state()
        n_cams = len(self.rig.camera_names)

        def enough() -> bool:
            return all(sum(f.t > t0 for f in self.rig.recent(c, self.frames)) >= self.frames for c in range(n_cams))

        waited = 0.0
        limit = 20 * self.frames * 0.01 + 1.0  # 100 frames/s: a stalled remote must not hang the run
        while not enough():
            pump(self.clock, self.rig, self.step, on_step=self._record_state, cancel=self.cancel)
            waited += self.step
            if waited > limit:
                return (
                    np.full(3, np.nan),
                    np.full((n_cams, 2), np.nan),
                    np.full((n_cams, 2), np.nan),
                    self.arm.state().q,
                    f"the remotes sent fewer than {self.frames} frames in {limit:.1f} s",
                )
        pixels = np.full((n_cams, 2), np.nan)
        spread = np.full((n_cams, 2), np.nan)
        problems = []
        for c in range(n_cams):
            recent = [f for f in self.rig.recent(c, self.frames) if f.t > t0]
            one = [f.dots[f.visible][0] for f in recent if int(f.visible.sum()) == 1]
            many = sum(int(f.visible.sum()) > 1 for f in recent)
            if len(one) * 2 <= len(recent):
                what = f"{many} frames with several dots (another IR source is lit)" if many else "no dot"
                problems.append(
                    f"cam{c} does not see the marker ({len(one)} of {len(recent)} frames with one dot; {what})"
                )
                continue
            pixels[c] = np.mean(one, axis=0)
            spread[c] = np.std(one, axis=0)
        qs = np.array([q for _, q in self._samples])
        position = np.mean([self.marker_link1(q) for q in qs], axis=0)
        return position, pixels, spread, qs.mean(axis=0), "; ".join(problems)

    # -- the run --------------------------------------------------------------------------------

    def run(
        self,
        plan: PosePlan,
        n: int | None = None,
        *,
        progress: Progress | None = None,
        show_progress: bool = True,
        max_replacements: int | None = None,
    ) -> PoseData:
        """Measure `n` poses (default: all of the plan's), replacing skipped ones from its reserve."""
        n = len(plan) if n is None else int(n)
        queue = [_Pose(p, q) for p, q in zip(plan.positions, plan.q)]
        reserve_used = np.zeros(len(plan.reserve_positions), dtype=bool)
        max_replacements = n if max_replacements is None else max_replacements
        positions: list[NDArray[np.float64]] = []
        image: list[NDArray[np.float64]] = []
        spread: list[NDArray[np.float64]] = []
        joints: list[NDArray[np.float64]] = []
        targets: list[NDArray[np.float64]] = []
        skipped: list[SkippedPose] = []
        t_start = self.clock.now()
        bar = progress_bar(total=n, show=show_progress, desc="calibration poses", unit="pose", leave=False)
        try:
            while len(positions) < n:
                if not queue:
                    pose = None
                    if skipped and len(skipped) <= max_replacements:
                        pose = self._replacement(plan, reserve_used, skipped[-1].target)
                    if pose is None:
                        raise AppError(
                            f"only {len(positions)} of {n} poses could be measured ({len(skipped)} skipped: "
                            f"{skipped[-1].reason if skipped else 'the plan ran out'}); check that the rig sees "
                            "the hand's LED and that it is the only lit IR source"
                        )
                    queue.append(pose)
                pose = queue.pop(0)
                if is_cancelled(self.cancel):
                    raise Cancelled("cancelled")
                try:
                    q_goal = self.solve(pose)
                except RobotError as exc:
                    skipped.append(SkippedPose(pose.target, f"unreachable: {exc}"))
                    continue
                self.move(q_goal)
                position, pixels, std, q_mean, problem = self.measure()
                if problem:
                    skipped.append(SkippedPose(pose.target, problem))
                    bar.set_postfix_str(f"skipped {len(skipped)}")
                    continue
                positions.append(position)
                image.append(pixels)
                spread.append(std)
                joints.append(q_mean)
                targets.append(pose.target)
                bar.update(1)
                if progress is not None:
                    progress(
                        len(positions), n, f"pose {len(positions)}/{n} at {np.round(position, 3).tolist()} m (link1)"
                    )
        except Cancelled:
            self.arm.stop()
            raise CalibrationCancelled(
                f"calibration stopped after {len(positions)} of {n} poses; the arm was stopped and nothing was saved"
            ) from None
        finally:
            bar.close()
        return PoseData(
            np.array(positions),
            np.stack(image, axis=1),
            np.stack(spread, axis=1),
            np.array(joints),
            np.array(targets),
            skipped,
            self.clock.now() - t_start,
        )

    def _replacement(self, plan: PosePlan, used: NDArray[np.bool_], near: NDArray[np.float64]) -> _Pose | None:
        """The unused reserve candidate nearest to a skipped pose."""
        if used.all():
            return None
        d = np.linalg.norm(plan.reserve_positions - near, axis=1)
        d[used] = np.inf
        i = int(np.argmin(d))
        used[i] = True
        return _Pose(plan.reserve_positions[i], plan.reserve_q[i])


# --------------------------------------------------------------------------------------------
# The whole calibration


@dataclass(frozen=True)
class RobotCalibration:
    """A finished robot-driven calibration: the rig's `calibration` (in link1), its leave-one-out
    errors, the measured `data`, the `plan` it followed and where it was saved (or None)."""

    calibration: StereoCalibration
    loo: LeaveOneOut
    data: PoseData
    plan: PosePlan
    path: Path | None = None
    meta: dict[str, Any] = field(default_factory=dict)

    @property
    def rms_px(self) -> list[float]:
        return [c.rms_px for c in self.calibration.cameras]


def calibrate_with_robot(
    arm: Arm,
    arm_model: ArmModel,
    rig: MarkerSource,
    clock: Clock,
    cameras: Sequence[WiimoteCamera],
    *,
    n_poses: int = DEFAULT_POSES,
    plan: PosePlan | None = None,
    design: Design = "optimal",
    method: Method = "refined",
    kinematics: Kinematics = "identified",
    frames: int = 10,
    settle_s: float = 0.3,
    poll_step_s: float = 0.01,
    out: str | os.PathLike[str] | None = None,
    meta: dict[str, Any] | None = None,
    rng: np.random.Generator | None = None,
    progress: Progress | None = None,
    cancel: Cancel = None,
    show_progress: bool = True,
) -> RobotCalibration:
    """Calibrate the rig with the robot (see the module docstring) and save it to `out` if given.

    `cameras`: the NOMINAL cameras (where the settings put them), used to choose poses the rig
    should see; `plan`: poses to visit (default: `select_poses(..., design=design)` for
    `n_poses`); `frames`: frames averaged per pose; `rng`: for pose selection and IK restarts;
    `kinematics`: "identified" (the arm's kinematic errors fitted with the cameras) or "nominal".
    Raises CalibrationCancelled when cancelled, AppError when too few poses can be measured,
    CalibrationError when the points cannot calibrate a camera.
    """
    if kinematics not in KINEMATICS:
        raise AppError(f"unknown kinematics {kinematics!r}; choose one of {', '.join(KINEMATICS)}")
    rng = rng if rng is not None else np.random.default_rng(0)
    measurer = PoseMeasurer(
        arm,
        arm_model,
        rig,
        clock,
        cameras,
        frames=frames,
        settle_s=settle_s,
        poll_step_s=poll_step_s,
        cancel=cancel,
        rng=rng,
    )
    if plan is None:
        start = measurer.marker_link1(arm.state().q)
        plan = select_poses(arm_model, cameras, n_poses, rng, design=design, start=start, frames=frames)
    data = measurer.run(plan, min(n_poses, len(plan)), progress=progress, show_progress=show_progress)
    info = {
        "source": "robot",
        "arm": arm_model.name,
        "poses": len(data),
        "method": method,
        "design": plan.design,
        "frames_per_pose": frames,
        "settle_s": settle_s,
        "skipped": [{"target_link1": s.target.tolist(), "reason": s.reason} for s in data.skipped],
        "joints": data.q.tolist(),
        **(meta or {}),
    }
    points, info["kinematics"] = corrected_points(arm_model, data, kinematics)
    fit = calibrate_rig(points, data.image, method=method, frame="link1", meta=info)
    path = fit.calibration.save(out) if out is not None else None
    return RobotCalibration(fit.calibration, fit.loo, data, plan, path, info)


def corrected_points(
    arm_model: ArmModel, data: PoseData, kinematics: Kinematics
) -> tuple[NDArray[np.float64], dict[str, Any]]:
    """The calibration points for the camera fit and what was done to them (for the meta): the
    measured FK positions, corrected by the identified kinematic errors when asked and the poses
    are enough for it (`kinematic.identify_kinematics`)."""
    if kinematics == "nominal":
        return data.positions, {"kinematics": "nominal"}
    if len(data) < MIN_POSES_IDENTIFIED:
        return data.positions, {
            "kinematics": "nominal",
            "why": f"{len(data)} poses are too few to identify the arm's kinematics (at least {MIN_POSES_IDENTIFIED})",
        }
    identified = identify_kinematics(arm_model, data.q, data.image, data.positions)
    return identified.positions, identified.to_meta()


@dataclass(frozen=True)
class RobotCalibrationOptions:
    """How a robot-driven calibration runs (`calibrate_in_world`; the parameters of
    `calibrate_with_robot` of the same names): `n_poses` poses of a plan chosen by `design`
    (or `plan`), each averaged over `frames` frames taken `settle_s` after the arm stopped, the
    remotes read every `poll_step_s`; fitted by `method` on points by the `kinematics` (the arm's
    errors identified with the cameras, or nominal); saved to `out` with `meta` when given; a
    progress bar on a terminal when `show_progress`."""

    n_poses: int = DEFAULT_POSES
    plan: PosePlan | None = None
    design: Design = "optimal"
    method: Method = "refined"
    kinematics: Kinematics = "identified"
    frames: int = 10
    settle_s: float = 0.3
    poll_step_s: float = 0.01
    out: str | os.PathLike[str] | None = None
    meta: dict[str, Any] = field(default_factory=dict)
    show_progress: bool = True


def calibrate_in_world(
    world: RigWorld,
    options: RobotCalibrationOptions | None = None,
    *,
    rng: np.random.Generator | None = None,
    progress: Progress | None = None,
    cancel: Cancel = None,
) -> RobotCalibration:
    """`calibrate_with_robot` with a world's arm, rig and clock, its cameras where the settings put
    them, run as `options` say; the world's marker LED must be lit."""
    o = options if options is not None else RobotCalibrationOptions()
    return calibrate_with_robot(
        world.arm,
        world.arm_model,
        world.rig,
        world.clock,
        nominal_cameras(world.settings.rig),
        n_poses=o.n_poses,
        plan=o.plan,
        design=o.design,
        method=o.method,
        kinematics=o.kinematics,
        frames=o.frames,
        settle_s=o.settle_s,
        poll_step_s=o.poll_step_s,
        out=o.out,
        meta=o.meta,
        rng=rng,
        progress=progress,
        cancel=cancel,
        show_progress=o.show_progress,
    )
