"""What the session and the world refuse from a lab's files and an operator's numbers: a target
no throw reaches, a training area beyond the arm, a calibration of another arm (old files: by
their meta), a calibration too large to read back; and a learning library's history stays
bounded. One line each; nothing changes."""

from __future__ import annotations

import math

import numpy as np
import pytest

from wiithrow.app.errors import AppError
from wiithrow.app.session import simulated_session
from wiithrow.app.worlds import SimWorld
from wiithrow.app.worlds.base import check_calibration_fits, unknown_arm_warning
from wiithrow.throwing import Area, ThrowParameters, TrainedThrow, online
from wiithrow.throwing.online import OnlineLibrary
from wiithrow.vision import StereoCalibration
from wiithrow.vision.errors import FileTooLargeError
from wiithrow.vision.files import SizeBound


@pytest.fixture(scope="module")
def session():
    s = simulated_session(seed=3, calibration="true", quiet=True)
    yield s
    s.close()


def test_the_session_refuses_a_target_or_an_area_no_throw_reaches(session):
    before = session.snapshot().target_base.copy()
    for target in ((1e300, 0.0, 0.2), (1.0, math.nan, 0.0)):
        with pytest.raises(AppError) as err:
            session.set_target(target)  # the dashboard's drag lands here
        assert "\n" not in str(err.value) and "the target (" in str(err.value)
    assert np.array_equal(session.snapshot().target_base, before, equal_nan=True)
    with pytest.raises(AppError, match=r"the area's corner x 1e\+09 z 0 m is beyond the reach of arm pa10"):
        session.start_training(Area((1.0, 1e9), (0.0, 0.3)), 5)
    assert session.snapshot().training is None


def test_a_calibration_of_another_arm_is_refused_by_the_world(tmp_path):
    world = SimWorld(seed=0)
    true = world.true_calibration()
    assert true.arm == "pa10"
    panda = StereoCalibration(true.cameras, "link1", None, {"source": "robot", "arm": "panda"})  # an old file's meta
    assert panda.arm == "panda"
    path = tmp_path / "panda.json"
    panda.save(path)
    loaded = StereoCalibration.load(path)
    assert loaded.arm == "panda"
    with pytest.raises(AppError, match="was made on arm 'panda' \\(frame link1\\), and this arm is 'pa10'"):
        world.set_calibration(loaded)
    assert world.calibration is None  # nothing changed
    unknown = StereoCalibration(true.cameras, "link1")  # made from points, or before the arm was recorded
    check_calibration_fits(unknown, remotes=2, frame="link1", arm="pa10")
    assert "does not say which arm it was made on" in (unknown_arm_warning(unknown, "pa10") or "")
    assert unknown_arm_warning(true, "pa10") is None
    assert true.fingerprint == StereoCalibration.load(true.save(tmp_path / "t.json")).fingerprint


def test_a_calibration_larger_than_it_may_be_read_back_is_not_written(tmp_path, monkeypatch):
    import wiithrow.vision.stereo_calibration as module

    calibration = SimWorld(seed=0).true_calibration()
    path = tmp_path / "cal.json"
    path.write_text("the old file\n")
    monkeypatch.setattr(module, "CALIBRATION_SIZE", SizeBound(1000, "a calibration", "a test's bound"))
    with pytest.raises(FileTooLargeError, match="more than a calibration file may be .*not written"):
        calibration.save(path)
    assert path.read_text() == "the old file\n" and sorted(p.name for p in tmp_path.iterdir()) == ["cal.json"]


def test_a_learning_librarys_history_keeps_its_newest_updates(monkeypatch):
    from wiithrow.app.throws.library_file import load_library

    monkeypatch.setattr(online, "MAX_HISTORY", 3)
    learning = OnlineLibrary.start(load_library())
    base = learning.library.throws[0]
    for k in range(5):
        landing = base.landing + np.array([0.001 * k, 0.0])
        learning.add(
            TrainedThrow(landing, ThrowParameters(base.params.q_release, base.params.dq_release), landing),
            time=f"t{k}",
            source="test",
        )
    assert [u.time for u in learning.history] == ["t2", "t3", "t4"] and learning.history_dropped == 2
    again = OnlineLibrary.start(learning.library)
    assert [u.time for u in again.history] == ["t2", "t3", "t4"] and again.history_dropped == 2
