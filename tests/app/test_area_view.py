"""The rig sees the training area (`wiithrow.app.throws.area_view`): before a run starts, the area
with 10 cm around it, at its heights, must be in the common view of the calibration's cameras. The
default rig sees the default area of every shipped arm that throws; an area it does not see is
refused in one line naming the corner, the cameras and what to change; the session's Start training
(the dashboard's and `wiithrow train`'s) refuses it before anything moves."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from wiithrow.app.errors import AppError
from wiithrow.app.session import simulated_session
from wiithrow.app.settings import RigSettings, Settings
from wiithrow.app.throws.area_view import (
    AREA_VIEW_MARGIN_M,
    VIEW_MARGIN_PX,
    area_not_seen,
    area_view_points,
    calibrated_cameras,
    require_area_in_view,
)
from wiithrow.app.worlds.base import nominal_cameras
from wiithrow.robot.arms import known_arms, load_arm
from wiithrow.throwing import Area, ThrowingError, training_area
from wiithrow.vision.rig import in_common_view

#: The rig mount this project shipped before the area was checked (centre 0.10 m ahead of joint 1's
#: axis in link1, 6 degrees down): it missed the near edge of every shipped area at the floor.
OLD_CENTER = (0.10, 0.0, 0.35)


def slack_px(cameras, points) -> float:
    """How far (px) inside the `VIEW_MARGIN_PX` margin the worst of `points` projects, over cameras."""
    worst = np.inf
    for c in cameras:
        uv = c.project(points)
        inside = np.minimum.reduce([uv[:, 0], c.width - 1 - uv[:, 0], uv[:, 1], c.height - 1 - uv[:, 1]])
        worst = min(worst, float(inside.min()) - VIEW_MARGIN_PX)
    return worst


@pytest.mark.parametrize("name", known_arms())
def test_the_default_rig_sees_the_default_area_of_every_shipped_arm(name, sim_world):
    arm = load_arm(name)
    try:
        area = training_area(arm)
    except ThrowingError:  # the UR5 ships with kinematics only: no throwing section, no area to train
        assert name == "ur5"
        return
    points = np.array([p.position for p in area_view_points(area)])
    for cameras in (nominal_cameras(Settings().rig), calibrated_cameras(sim_world.true_calibration().Ps)):
        assert area_not_seen(area, cameras) is None
        # measured: 33 px to spare beyond the margin at the near corners at the floor, for every arm
        assert slack_px(cameras, points) > 25.0, slack_px(cameras, points)


def test_the_old_rig_mount_missed_the_near_edge_and_says_which_corner_and_what_to_change():
    old = nominal_cameras(dataclasses.replace(RigSettings(), center=OLD_CENTER))
    area = Area((1.0, 1.6), (0.0, 0.4))
    line = area_not_seen(area, old)
    assert line is not None and len(line.splitlines()) == 1
    assert "near left at z = 0.0 m" in line and "x 0.90, y +0.10 m" in line, line
    assert "cam0" in line and "cam1" in line and "below its image" in line and "pitch the rig down" in line, line
    assert "recalibrate" in line and "move the area" in line, line
    # the lab's landing 34 mm short of the near edge (x 0.966 m at the floor) was invisible then
    assert not in_common_view(old, [[1.0 - 0.034, 0.0, 0.0]], VIEW_MARGIN_PX)[0]
    assert in_common_view(nominal_cameras(RigSettings()), [[1.0 - 0.034, 0.0, 0.0]], VIEW_MARGIN_PX)[0]


def test_the_points_are_the_areas_corners_and_edges_with_the_margin_at_its_heights():
    points = area_view_points(Area((1.0, 1.4), (0.0, 0.3)))
    positions = np.array([p.position for p in points])
    assert positions[:, 0].min() == pytest.approx(1.0 - AREA_VIEW_MARGIN_M)
    assert positions[:, 0].max() == pytest.approx(1.4 + AREA_VIEW_MARGIN_M)
    assert set(np.round(positions[:, 1], 9)) >= {AREA_VIEW_MARGIN_M, -AREA_VIEW_MARGIN_M}
    assert set(positions[:, 2]) == {0.0, 0.3}
    names = [p.name for p in points]
    assert names[:4] == ["near left at z = 0.0 m", "near right at z = 0.0 m", "far left at z = 0.0 m",
                         "far right at z = 0.0 m"]  # fmt: skip
    assert "right edge at z = 0.3 m" in names


@pytest.mark.parametrize(
    "area, needle, remedy",
    [
        (Area((0.5, 0.9), (0.0, 0.2)), "near left at z = 0.0 m", "pitch the rig down"),
        (Area((1.2, 1.6), (0.6, 0.9)), "near left at z = 0.6 m", "pitch the rig up"),
    ],
    ids=["too close", "too high"],
)
def test_an_area_the_rig_does_not_see_is_refused_in_one_line(sim_world, area, needle, remedy):
    cameras = calibrated_cameras(sim_world.true_calibration().Ps)
    with pytest.raises(AppError) as refused:
        require_area_in_view(area, sim_world.true_calibration().Ps)
    line = str(refused.value)
    assert line == area_not_seen(area, cameras) and len(line.splitlines()) == 1
    assert needle in line and remedy in line, line


def test_start_training_refuses_an_area_the_rig_does_not_see_before_anything_moves(tmp_path):
    session = simulated_session(seed=3, calibration="true", quiet=True)
    try:
        session.train_to(tmp_path / "lib.json")
        q = session.world.arm.state().q
        with pytest.raises(AppError, match="does not see the training area's near left at z = 0.0 m"):
            session.start_training(Area((0.6, 1.0), (0.0, 0.2)), 6)
        assert session.snapshot().training is None and not (tmp_path / "lib.training.json").exists()
        assert np.allclose(session.world.arm.state().q, q)
        run = session.start_training(training_area(session.world.arm_model), 6)  # the default area: seen
        assert run.count == 6
    finally:
        session.close()
