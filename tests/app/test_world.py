"""The simulated world: sources seen through the rig on link 1, on one clock."""

import numpy as np
import pytest

from wiithrow.app.rig.waiting import pump
from wiithrow.app.worlds import SOURCES, SimWorld


@pytest.fixture(scope="module")
def world():
    w = SimWorld(seed=1)
    w.light("marker")
    w.arm.command_position(np.array([0.4, 0.6, 0.0, 1.2, 0.0, 0.5, 0.0]))
    w.connect()
    pump(w.clock, w.rig, 3.0, step_s=0.001)
    return w


def test_remotes_report_the_hand_led_where_the_cameras_see_it(world):
    led = world.sources_at(world.clock.now())[0]
    for c, camera in enumerate(world.cameras):
        frame = world.rig.latest[c]
        assert np.linalg.norm(frame.dots[0] - camera.project(led[None])[0]) < 3.0  # noise 0.5 px, rounding
        assert np.isnan(frame.dots[1:]).all()


def test_link1_turns_with_joint_1(world):
    q = world.arm.state().q
    p = world.source_positions_base(q)[0]
    local = world.base_to_link1(p, q)[0]
    assert abs(np.arctan2(p[1], p[0]) - q[0]) < 1e-2 and abs(local[1]) < 1e-2  # S3 = E2 = 0: in y = 0
    assert np.allclose(world.link1_to_base(local, q)[0], p)


def test_sources_have_fixed_indices_and_need_positions(world):
    assert SOURCES.index("target") == 1
    with pytest.raises(ValueError, match="needs a position"):
        world.light("landing")
    with pytest.raises(ValueError, match="unknown IR source"):
        world.light("sun")
    world.light("target", position_base=[1.5, 0.0, 0.0])
    positions = world.source_positions_base()
    assert np.allclose(positions[1], [1.5, 0, 0]) and np.isnan(positions[2]).all()
    world.light("target", False)


def test_a_calibration_must_fit_the_rig_it_is_used_with(sim_world):
    """Three calibrated cameras for two remotes was a traceback ("2 drivers for 3 calibrated
    cameras"); a calibration in `base` was used as if it were in link1."""
    from wiithrow.app.errors import AppError
    from wiithrow.app.worlds.base import check_calibration_fits
    from wiithrow.vision import StereoCalibration
    from wiithrow.vision.rig import stereo_rig

    true = sim_world.true_calibration()
    check_calibration_fits(true, remotes=2)
    three = StereoCalibration((*true.cameras, _camera(stereo_rig(count=3, baseline=0.3)[2].P, "cam2")), "link1")
    with pytest.raises(AppError, match="the calibration has 3 cameras and the rig 2 remotes"):
        check_calibration_fits(three, remotes=2)
    base = StereoCalibration(true.cameras, "base")
    with pytest.raises(AppError, match="in frame 'base'.*link1"):
        check_calibration_fits(base, remotes=2, frame="link1")
    check_calibration_fits(base, remotes=2)  # a command that labels points with the frame takes any
    world = SimWorld(seed=2)
    with pytest.raises(AppError, match="3 cameras"):
        world.set_calibration(three)
    assert world.calibration is None


def _camera(P, name):
    from wiithrow.vision.dlt import CalibratedCamera

    empty = (np.zeros((0, 3)), np.zeros((0, 2)), np.zeros(0), np.zeros(0, bool))
    return CalibratedCamera(P, "true", *empty, name=name)
