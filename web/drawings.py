"""What the scene draws of the session's results, computed once per change: the rig's cameras
(from the calibration, or the nominal ones before it), a preview's ghost arm and ball, and the
previewed joint speeds against their limits."""

from __future__ import annotations

import numpy as np

from wiithrow.app.session import ThrowPreview
from wiithrow.app.worlds import RigWorld, nominal_cameras
from wiithrow.web.scene import CameraPose, PreviewDrawing


def camera_poses(world: RigWorld) -> list[CameraPose]:
    """The rig's cameras in link1: decomposed from the calibration, or the nominal ones before one."""
    calibration = world.calibration
    if calibration is not None:
        poses = []
        try:
            for k, camera in enumerate(calibration.cameras):
                d = camera.decompose()
                w, h = camera.image_size
                poses.append(CameraPose(camera.name or f"cam{k}", d.K, d.R, d.t, True, int(w), int(h)))
            return poses
        except Exception:  # a degenerate calibration: show the nominal rig instead
            pass
    return [CameraPose(c.name, c.K, c.R, c.t, False, c.width, c.height) for c in nominal_cameras(world.settings.rig)]


def preview_drawing(preview: ThrowPreview, world: RigWorld, step_s: float = 0.02) -> PreviewDrawing:
    """The preview sampled every `step_s` for the ghost: the planned joints (held at the end while
    the ball still flies) and the ball, in the hand until the release, then on its arc (at the
    arc's own times: `ThrowPreview.arc_times`)."""
    traj = preview.throw.trajectory
    times, Q = np.asarray(traj.times, float), np.asarray(traj.positions, float)
    release = float(preview.throw.release_time)
    arc = np.asarray(preview.arc_base, float)
    arc_times = np.asarray(preview.arc_times, float)
    end = max(float(times[-1]), release + float(arc_times[-1]))
    t = np.arange(0.0, end + 1e-9, step_s)
    k = np.minimum(np.searchsorted(times, t), len(times) - 1)
    q = Q[k]
    hand = world.arm_model.frame_positions(q, "ball")
    k_arc = np.clip(np.searchsorted(arc_times, t - release, side="right") - 1, 0, len(arc) - 1)
    ball = np.where((t >= release)[:, None], arc[k_arc], hand)
    landing = np.asarray(preview.predicted_base, float)
    return PreviewDrawing(preview.id, step_s, q, ball, arc, landing, release, arc_times)


def speed_ratios(preview: ThrowPreview, step_s: float = 0.02) -> tuple[np.ndarray, np.ndarray]:
    """Times (K,) and |dq_j| / limit_j (K, nq) of the previewed motion."""
    traj = preview.throw.trajectory
    times = np.asarray(traj.times, float)
    k = np.minimum(np.searchsorted(times, np.arange(0.0, times[-1] + 1e-9, step_s)), len(times) - 1)
    return times[k], np.abs(np.asarray(traj.velocities, float)[k]) / preview.velocity_limit
