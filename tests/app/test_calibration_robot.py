"""The robot-driven calibration on the simulated world: accuracy against the true cameras,
skipped poses, cancellation, the saved file, and arms other than the PA-10."""

import threading

import numpy as np
import pytest

from wiithrow.app.calibration.poses import PosePlan, sample_candidates, score_calibration, select_poses
from wiithrow.app.calibration.robot import CalibrationCancelled, PoseMeasurer, calibrate_with_robot
from wiithrow.app.errors import AppError
from wiithrow.app.rig.source import newest_t
from wiithrow.app.rig.waiting import pump
from wiithrow.app.settings import Settings
from wiithrow.app.worlds import SimWorld, nominal_cameras
from wiithrow.vision import StereoCalibration


def _world(settings=None, seed=0):
    world = SimWorld(settings, seed=seed)
    world.light("marker")
    world.connect()
    return world, nominal_cameras(world.settings.rig)


@pytest.fixture(scope="module")
def pa10_run(tmp_path_factory):
    world, cameras = _world(seed=0)
    updates = []
    out = tmp_path_factory.mktemp("cal") / "calibration.json"
    result = calibrate_with_robot(
        world.arm,
        world.arm_model,
        world.rig,
        world.clock,
        cameras,
        n_poses=30,
        out=out,
        rng=np.random.default_rng(0),
        show_progress=False,
        progress=lambda done, total, msg: updates.append((done, total)),
    )
    test = sample_candidates(world.arm_model, cameras, np.random.default_rng(5)).positions
    truth = score_calibration(result.calibration.Ps, world.cameras, test, np.random.default_rng(6))
    return world, result, truth, updates


def test_thirty_poses_calibrate_as_well_as_the_true_cameras(pa10_run):
    _, result, truth, _ = pa10_run
    assert len(result.data) == 30 and not result.data.skipped
    assert result.loo.mean < 0.6e-3  # measured 0.27 mm (10 frames per pose, sigma 0.5 px)
    assert truth.ratio <= 1.10  # measured 1.003
    assert truth.calibration_m < 0.2e-3
    assert all(rms < 0.5 for rms in result.rms_px)
    # ground truth is FK of the measured joints: within the joint tracking error of the asked position
    assert np.abs(result.data.positions - result.data.targets).max() < 3e-3
    assert np.all(result.data.q[:, 0] == pytest.approx(0.0, abs=5e-3))  # joint 1 stayed where it was


def test_calibration_file_has_meta_and_progress_was_reported(pa10_run):
    _, result, _, updates = pa10_run
    loaded = StereoCalibration.load(result.path)
    assert loaded.frame == "link1" and np.allclose(loaded.Ps, result.calibration.Ps)
    assert loaded.meta["arm"] == "pa10" and loaded.meta["poses"] == 30 and loaded.meta["method"] == "refined"
    assert np.array(loaded.meta["joints"]).shape == (30, 7)
    assert loaded.loo_error_m == pytest.approx(result.loo.mean)
    assert [u[0] for u in updates] == list(range(1, 31)) and {u[1] for u in updates} == {30}


def test_calibration_holds_at_another_joint_1_angle(pa10_run):
    """Calibrated in link1, the rig measures the hand correctly wherever joint 1 turns."""
    world, result, _, _ = pa10_run
    world.set_calibration(result.calibration)
    q = world.arm.state().q.copy()
    q[0] = 0.8
    world.arm.command_position(q)
    pump(world.clock, world.rig, 3.0, step_s=0.01)
    since = newest_t(world.rig)
    pump(world.clock, world.rig, 0.3, step_s=0.01)
    frames = world.rig.tracked_since(since)
    seen = [f.position[0] for f in frames if len(f) and f.visible[0]]
    truth = world.base_to_link1(world.arm_model.frame_position(world.arm.state().q, "marker"))[0]
    assert len(seen) > 10 and np.linalg.norm(np.mean(seen, axis=0) - truth) < 3e-3


def test_unseen_pose_is_skipped_and_replaced(pa10_run):
    world, result, _, _ = pa10_run
    cameras = nominal_cameras(world.settings.rig)
    plan = result.plan
    home = world.arm_model.home.copy()  # the marker at home is above the cameras' view
    unseen = world.arm_model.frame_position(home, "marker")
    tiny = PosePlan(
        "test",
        np.vstack([unseen, plan.positions[:6]]),
        np.vstack([home, plan.q[:6]]),
        plan.reserve_positions,
        plan.reserve_q,
        1.0,
        plan.test_points,
    )
    w, _ = _world(seed=3)
    measurer = PoseMeasurer(w.arm, w.arm_model, w.rig, w.clock, cameras)
    data = measurer.run(tiny, show_progress=False)
    assert len(data) == 7 and len(data.skipped) == 1
    assert "does not see the marker" in data.skipped[0].reason
    assert np.allclose(data.skipped[0].target, unseen)
    assert not any(np.allclose(t, unseen) for t in data.targets)


def test_another_lit_source_makes_poses_fail_with_a_clear_error():
    world, cameras = _world(seed=4)
    world.light("target", True, [0.7, 0.0, 0.25])  # a second dot in both cameras
    plan = select_poses(
        world.arm_model,
        cameras,
        6,
        np.random.default_rng(0),
        candidates=sample_candidates(world.arm_model, cameras, np.random.default_rng(0), n_uniform=800, n_walk=600),
    )
    with pytest.raises(AppError, match="only 0 of 6 poses"):
        PoseMeasurer(world.arm, world.arm_model, world.rig, world.clock, cameras).run(
            plan, show_progress=False, max_replacements=1
        )


def test_cancel_stops_the_arm_and_saves_nothing(tmp_path):
    world, cameras = _world(seed=5)
    stop = threading.Event()
    out = tmp_path / "never.json"

    def progress(done, total, message):
        if done == 2:
            stop.set()

    plan = select_poses(
        world.arm_model,
        cameras,
        10,
        np.random.default_rng(1),
        candidates=sample_candidates(world.arm_model, cameras, np.random.default_rng(1), n_uniform=800, n_walk=800),
    )
    with pytest.raises(CalibrationCancelled, match="after 2 of 10 poses"):
        calibrate_with_robot(
            world.arm,
            world.arm_model,
            world.rig,
            world.clock,
            cameras,
            n_poses=10,
            plan=plan,
            out=out,
            progress=progress,
            cancel=stop,
            show_progress=False,
        )
    pump(world.clock, world.rig, 2.0, step_s=0.01)
    assert not world.arm.is_moving() and not out.exists()


@pytest.mark.parametrize("arm", ["ur5"])
def test_robot_calibration_with_another_arm(arm):
    """The same procedure on the UR5 (its own reach: candidates come from its kinematics)."""
    world, cameras = _world(Settings().replace(arm=arm), seed=7)
    result = calibrate_with_robot(
        world.arm,
        world.arm_model,
        world.rig,
        world.clock,
        cameras,
        n_poses=15,
        rng=np.random.default_rng(7),
        show_progress=False,
    )
    test = sample_candidates(world.arm_model, cameras, np.random.default_rng(8), n_uniform=1500, n_walk=1500).positions
    truth = score_calibration(result.calibration.Ps, world.cameras, test, np.random.default_rng(9))
    assert result.meta["arm"] == arm and len(result.data) == 15
    assert result.loo.mean < 1.5e-3 and truth.ratio <= 1.10
