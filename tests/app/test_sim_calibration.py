"""The simulated rig's robot calibration, kept and reused while valid (throw and train without
--calibration recalibrated for a minute every time)."""

import numpy as np
import pytest

from wiithrow.app.calibration.simulated import cache_dir, simulated_rig_calibration
from wiithrow.app.session import simulated_session
from wiithrow.app.settings import Settings


@pytest.fixture()
def own_cache(tmp_path, monkeypatch):
    monkeypatch.setenv("WIITHROW_CACHE_DIR", str(tmp_path / "cache"))
    return tmp_path / "cache"


def test_the_last_calibration_is_reused_while_valid_and_each_run_says_which(own_cache):
    said = []
    first = simulated_rig_calibration(Settings(), seed=3, poses=7, say=said.append, show_progress=False)
    assert cache_dir() == own_cache and len(list(own_cache.iterdir())) == 1
    assert said[0].startswith("calibrating the simulated rig") and said[-1].startswith("kept it in")
    said.clear()
    again = simulated_rig_calibration(Settings(), seed=3, poses=7, say=said.append, show_progress=False)
    assert np.array_equal(again.Ps, first.Ps) and len(said) == 1 and said[0].startswith("reusing")
    said.clear()
    fresh = simulated_rig_calibration(Settings(), seed=3, poses=7, reuse=False, say=said.append, show_progress=False)
    assert np.allclose(fresh.Ps, first.Ps) and said[0].startswith("calibrating")
    said.clear()
    other = simulated_rig_calibration(Settings(), seed=4, poses=7, say=said.append, show_progress=False)
    assert said[0].startswith("calibrating") and not np.array_equal(other.Ps, first.Ps)
    assert len(list(own_cache.iterdir())) == 2


def test_a_corrupt_kept_calibration_is_said_and_replaced(own_cache):
    simulated_rig_calibration(Settings(), seed=5, poses=7, show_progress=False)
    (kept,) = own_cache.iterdir()
    kept.write_text(kept.read_text()[:100])
    said = []
    simulated_rig_calibration(Settings(), seed=5, poses=7, say=said.append, show_progress=False)
    assert said[0].startswith(f"not reusing {kept}") and "not valid JSON" in said[0]
    assert said[1].startswith("calibrating")


def test_an_unwritable_cache_is_said_and_ignored(tmp_path, monkeypatch):
    (tmp_path / "afile").write_text("x")
    monkeypatch.setenv("WIITHROW_CACHE_DIR", str(tmp_path / "afile" / "cache"))
    said = []
    calibration = simulated_rig_calibration(Settings(), seed=5, poses=7, say=said.append, show_progress=False)
    assert len(calibration.cameras) == 2 and said[-1].startswith("could not keep it")


def test_a_run_that_reuses_gives_the_result_of_the_run_that_calibrated(own_cache):
    records = []
    for _ in range(2):
        session = simulated_session(seed=2, poses=12, reuse_calibration=True, quiet=True)
        session.set_target([1.3, 0.1, 0.0])
        assert session.align().converged
        preview = session.plan_preview()
        records.append(session.throw(preview.id))
        session.close()
    assert np.array_equal(records[0].landing_xz, records[1].landing_xz)
    assert records[0].error_m == records[1].error_m
