"""The rig watches the arm move: `probe_seen_moving`, the check "seen moving".

Every other check believes the arm's state. This one asks the calibrated rig (its tracked markers
in link1) where the hand's LED, the robot calibration's `marker` frame, really is while the arm
moves, and compares with where the state puts it by forward kinematics:

1. the LED is lit (`RigWatch.light`, as the robot calibration lights it: through the arm's
   driver where it can switch it, else the operator);
2. the arm goes, slowly (`motions.slow_move`), to a pose near where it is that puts the LED in
   every camera's view facing the rig (`view_pose`: inverse kinematics for points of the common
   view, joint 1 where it is), moves every joint out and back there (`motions.slow_out_and_back`)
   and comes back; states are read every `STEP_S` and the rig's frames kept meanwhile;
3. for every frame with a state read within `bounds.RIG_STATE_GAP_MAX_S` before and after it, the
   state's LED p_state = FK(q(t_f)) in link1 (q interpolated at the frame's time); where it lies in
   the rig's common view, the marker nearest to it within `bounds.RIG_GATE_M` is the LED seen;
4. judged: the rig saw the LED in at least `RIG_SEEN_FRACTION_MIN` of those frames, within
   `RIG_ERROR_RMS_MAX_M` (RMS) and `RIG_ERROR_MAX_M` of the state's, and its travel (the extent
   of its positions) is at least `RIG_TRAVEL_FRACTION_MIN` of the state's: a state that says the
   arm moved where the rig did not see the LED move fails, with the figures.

Frames the host read no state around are counted (`host_late_frames`) and not judged: a loaded
host's lateness is not the driver's (too few frames left to judge because of them is the host's:
`figures["host_late"]`, and the check is tried again). Without a calibrated rig the check is not run, and says so.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from wiithrow.app.drivercheck import bounds, motions
from wiithrow.app.drivercheck.probes import Samples, command
from wiithrow.app.drivercheck.report import CheckResult, judged, not_run
from wiithrow.app.errors import AppError
from wiithrow.app.rig.source import MarkerSource, newest_t
from wiithrow.app.rig.waiting import pump
from wiithrow.app.worlds.base import RigWorld
from wiithrow.clock import Clock
from wiithrow.robot import Arm, ArmModel, JointTrajectory, RobotError
from wiithrow.robot.ik import solve_position
from wiithrow.vision.camera import WiimoteCamera
from wiithrow.vision.errors import VisionError
from wiithrow.vision.geometry import decompose
from wiithrow.vision.rig import in_common_view, points_in_common_view
from wiithrow.vision.tracked_frame import TrackedFrame

#: How often (s) the probe reads the arm (and lets the rig read its remotes): 500 Hz, plenty to
#: interpolate the joints at a frame's time during a slow motion.
STEP_S = 0.002
#: Points of the common view tried for the view pose, nearest to the LED first.
VIEW_CANDIDATES = 12
#: The LED at the view pose stays this high (m) above the floor.
FLOOR_CLEARANCE_M = 0.10
NO_RIG = (
    "no calibrated rig watches the arm: give check-driver --calibration (this rig's, in link1) so that "
    "the rig sees the hand's LED move as the state says"
)


@dataclass(frozen=True)
class RigWatch:
    """A calibrated rig that watches the hand's LED: `rig` (markers in link1), `cameras` (the rig's
    cameras in link1, as calibrated: which points it sees) and `light(on)` (the hand's LED)."""

    rig: MarkerSource
    cameras: Sequence[WiimoteCamera]
    light: Callable[[bool], None]


def rig_watch(world: RigWorld) -> RigWatch | None:
    """The watch of `world`'s rig, None while it is not calibrated. Its cameras are the
    calibration's (K [R | t] of each P, `wiithrow.vision.geometry.decompose`: where the rig looks,
    whatever the settings say of its mount), else the world's nominal ones."""
    if not world.rig.calibrated:
        return None
    cameras: Sequence[WiimoteCamera] = world.cameras
    if world.calibration is not None:
        try:
            parts = [decompose(P) for P in world.calibration.Ps]
            cameras = [WiimoteCamera(d.K, d.R, d.t, name=c.name) for d, c in zip(parts, world.cameras, strict=False)]
        except (VisionError, ValueError):
            cameras = world.cameras
    return RigWatch(world.rig, cameras, lambda on: world.light("marker", on))


def led_link1(model: ArmModel, q: NDArray[np.float64]) -> NDArray[np.float64]:
    """The hand's LED (the `marker` frame) in link1 at q (m)."""
    return model.to_frame(model.frame_position(q, "marker"), q, "link1").reshape(3)


def view_pose(
    model: ArmModel, cameras: Sequence[WiimoteCamera], q_now: NDArray[np.float64], rng: np.random.Generator
) -> NDArray[np.float64] | None:
    """A configuration near `q_now` (joint 1 kept) whose LED every camera sees
    `bounds.RIG_VIEW_MARGIN_PX` inside its image, facing the rig, that a slow move reaches (module
    docstring); None when no point of the common view is reachable so."""
    margin = bounds.RIG_VIEW_MARGIN_PX
    try:
        points = points_in_common_view(
            cameras, 4 * VIEW_CANDIDATES, rng, depth_m=bounds.RIG_VIEW_DEPTH_M, margin_px=margin
        )
    except VisionError:  # the cameras' views barely overlap at the arm's reach
        return None
    order = np.argsort(np.linalg.norm(points - led_link1(model, q_now), axis=1))
    centre = np.mean([c.center for c in cameras], axis=0)
    R1 = model.frame_placement(q_now, "link1")[:3, :3]
    for p in points[order[:VIEW_CANDIDATES]]:
        try:
            q = solve_position(
                model,
                "marker",
                model.from_frame(p, q_now, "link1").reshape(3),
                q_now,
                locked_joints=(0,),
                face_direction=R1 @ (centre - p),
                restarts=2,
                rng=rng,
            )
            motions.slow_move(model, q_now, q)  # validated: within the limits, above the floor
        except (RobotError, AppError):
            continue
        led = led_link1(model, q)
        if in_common_view(cameras, led[None], margin)[0] and model.frame_position(q, "marker")[2] > FLOOR_CLEARANCE_M:
            return q
    return None


@dataclass
class _Watched:
    """States and the rig's frames, as the probe reads them."""

    t: list[float]
    q: list[NDArray[np.float64]]
    frames: list[TrackedFrame]
    since: float


def _watch(arm: Arm, clock: Clock, rig: MarkerSource, traj: JointTrajectory, seen: _Watched) -> None:
    """Command `traj` and read the arm every `STEP_S` and the rig's new frames until it settled."""

    def read_state() -> None:
        s = arm.state()
        seen.t.append(float(s.t))
        seen.q.append(np.array(s.q, dtype=float))

    def read_frames() -> None:
        frames = rig.tracked_since(seen.since)
        if frames:
            seen.frames.extend(frames)
            seen.since = frames[-1].t

    command(arm, clock, traj)
    pump(clock, rig, traj.duration + bounds.SETTLE_S, step_s=STEP_S, on_step=read_state, on_read=read_frames)
    read_frames()


def compare(model: ArmModel, cameras: Sequence[WiimoteCamera], seen: _Watched) -> dict[str, Any]:
    """Where the rig saw the LED against where the state puts it, frame by frame (module docstring)."""
    new = Samples(np.array(seen.t), np.array(seen.t), np.array(seen.q), np.zeros((len(seen.t), model.nq))).new()
    in_view, host_late = 0, 0
    state_led, rig_led, errors = [], [], []
    for frame in seen.frames:
        k = int(np.searchsorted(new.t, frame.t))
        if (
            k == 0
            or k == new.t.size
            or frame.t - new.t[k - 1] > bounds.RIG_STATE_GAP_MAX_S
            or new.t[k] - frame.t > bounds.RIG_STATE_GAP_MAX_S
        ):
            host_late += 1
            continue
        w = (frame.t - new.t[k - 1]) / (new.t[k] - new.t[k - 1])
        p = led_link1(model, (1.0 - w) * new.q[k - 1] + w * new.q[k])
        if not in_common_view(cameras, p[None], 0.0)[0]:
            continue
        in_view += 1
        state_led.append(p)
        visible = frame.position[frame.visible]
        if visible.size:
            d = np.linalg.norm(visible - p, axis=1)
            i = int(np.argmin(d))
            if d[i] <= bounds.RIG_GATE_M:
                rig_led.append(visible[i])
                errors.append(float(d[i]))
    err = np.array(errors)

    def extent(points: list[NDArray[np.float64]]) -> float:
        return float(np.linalg.norm(np.ptp(np.array(points), axis=0))) if points else 0.0

    return {
        "frames": len(seen.frames),
        "host_late_frames": host_late,
        "frames_in_view": in_view,
        "frames_seen": len(errors),
        "seen_fraction": len(errors) / in_view if in_view else float("nan"),
        "error_rms_m": float(np.sqrt(np.mean(err**2))) if err.size else float("nan"),
        "error_max_m": float(np.max(err)) if err.size else float("nan"),
        "state_travel_m": extent(state_led),
        "rig_travel_m": extent(rig_led),
    }


def probe_seen_moving(
    arm: Arm, model: ArmModel, clock: Clock, watch: RigWatch | None, rng: np.random.Generator | None = None
) -> CheckResult:
    """The rig watches the LED while the arm moves, against the state (module docstring)."""
    if watch is None or not watch.rig.calibrated:
        return not_run("seen moving", NO_RIG)
    q_start = np.array(arm.state().q, dtype=float)
    q_view = view_pose(model, watch.cameras, q_start, rng if rng is not None else np.random.default_rng(0))
    if q_view is None:
        return not_run(
            "seen moving", "no pose near the arm's puts the hand's LED where every camera of the rig sees it"
        )
    # only frames taken from now on: the rig was not read during the probes before
    seen = _Watched([], [], [], max(newest_t(watch.rig), clock.now()))
    watch.light(True)
    try:
        _watch(arm, clock, watch.rig, motions.slow_move(model, q_start, q_view), seen)
        _watch(arm, clock, watch.rig, motions.slow_out_and_back(model, np.array(arm.state().q, dtype=float)), seen)
        _watch(arm, clock, watch.rig, motions.slow_move(model, np.array(arm.state().q, dtype=float), q_start), seen)
    finally:
        watch.light(False)
    figures = compare(model, watch.cameras, seen)
    limits = {
        "seen_fraction": {"min": bounds.RIG_SEEN_FRACTION_MIN},
        "error_rms_m": {"max": bounds.RIG_ERROR_RMS_MAX_M},
        "error_max_m": {"max": bounds.RIG_ERROR_MAX_M},
        "rig_travel_of_state": {"min": bounds.RIG_TRAVEL_FRACTION_MIN},
        "frames_in_view": {"min": bounds.RIG_MIN_FRAMES},
    }
    n, seen_n = figures["frames_in_view"], figures["frames_seen"]
    figures["rig_travel_of_state"] = (
        figures["rig_travel_m"] / figures["state_travel_m"] if figures["state_travel_m"] > 0 else float("nan")
    )
    late = (
        f" ({figures['host_late_frames']} frames the host read no state around not judged)"
        if figures["host_late_frames"]
        else ""
    )
    failures = []
    if n < bounds.RIG_MIN_FRAMES:
        failures.append(
            f"the state put the hand's LED in the rig's view in only {n} of {figures['frames']} frames "
            f"(< {bounds.RIG_MIN_FRAMES}) of a move to where it must be seen{late}"
        )
    elif figures["seen_fraction"] < bounds.RIG_SEEN_FRACTION_MIN:
        failures.append(
            f"the state put the hand's LED in the rig's view in {n} frames; the rig saw it there (within "
            f"{100 * bounds.RIG_GATE_M:.0f} cm) in {seen_n}: the arm is not where its state says (or the LED is off){late}"
        )
    if (
        n >= bounds.RIG_MIN_FRAMES
        and figures["rig_travel_m"] < bounds.RIG_TRAVEL_FRACTION_MIN * figures["state_travel_m"]
    ):
        failures.append(
            f"the state says the LED moved {figures['state_travel_m']:.3f} m in the rig's view; the rig saw it "
            f"move {figures['rig_travel_m']:.3f} m"
        )
    if seen_n and figures["error_rms_m"] > bounds.RIG_ERROR_RMS_MAX_M:
        failures.append(
            f"the rig saw the LED {1e3 * figures['error_rms_m']:.1f} mm (RMS) from where the state puts it "
            f"(> {1e3 * bounds.RIG_ERROR_RMS_MAX_M:.0f} mm)"
        )
    if seen_n and figures["error_max_m"] > bounds.RIG_ERROR_MAX_M:
        failures.append(
            f"the rig saw the LED up to {1e3 * figures['error_max_m']:.1f} mm from where the state puts it "
            f"(> {1e3 * bounds.RIG_ERROR_MAX_M:.0f} mm)"
        )
    if len(failures) == 1 and n < bounds.RIG_MIN_FRAMES <= n + figures["host_late_frames"]:
        # too few frames judged, for the frames the host read no state around: the host's
        figures["host_late"] = f"it read no state around {figures['host_late_frames']} of {figures['frames']} frames"
    summary = (
        f"the rig saw the LED in {seen_n} of {n} frames where the state put it in view, "
        f"{1e3 * figures['error_rms_m']:.1f} mm RMS ({1e3 * figures['error_max_m']:.1f} mm largest) from it, "
        f"moving {figures['rig_travel_m']:.2f} m of the state's {figures['state_travel_m']:.2f} m{late}"
    )
    return judged("seen moving", figures, limits, failures, summary)
