"""The simulated world: sources seen through the rig on link 1, on one clock."""

import numpy as np
import pytest

from wiithrow.app.worlds import SOURCES, SimWorld


@pytest.fixture(scope="module")
def world():
    w = SimWorld(seed=1)
    w.light("marker")
    w.arm.command_position(np.array([0.4, 0.6, 0.0, 1.2, 0.0, 0.5, 0.0]))
    w.advance(3.0)
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
