"""`wiithrow bench throwing --quick` runs the whole pipeline and reports every figure, in the
kinematic world and in MuJoCo's (the default), whose world flags it takes."""

import pytest

from tests.helpers.strict_json import loads_strict
from wiithrow.app.cli.main import main


def test_bench_throwing_quick_in_the_kinematic_world(capsys):
    assert main(["bench", "throwing", "--quick", "--world", "kinematic", "--json"]) == 0
    figures = loads_strict(capsys.readouterr().out)
    for key in (
        "median_error_m",
        "p95_error_m",
        "repeatability_m",
        "generalization_error_m",
        "plan_p50_ms",
        "plan_p99_ms",
        "plan_with_approach_p99_ms",
    ):
        assert figures[key] >= 0, key
    assert figures["failed_throws"] == 0
    assert figures["median_error_m"] < 0.02 and figures["repeatability_m"] < 0.02


@pytest.mark.slow
def test_bench_throwing_quick_in_mujoco_with_its_world_flags(capsys):
    argv = ["bench", "throwing", "--quick", "--json", "--release-latency-ms", "20", "--placement-sigma-mm", "2"]
    assert main(argv) == 0
    figures = loads_strict(capsys.readouterr().out)
    assert figures["world"] == "mujoco" and figures["failed_throws"] == 0
    assert figures["world_settings"]["release_latency_ms"] == pytest.approx(20.0)
    assert figures["world_settings"]["placement_sigma_mm"] == pytest.approx(2.0)
    # a reduced run (4 targets, 3 repeats): bounds of the order of the goals, not the goals
    assert 0 < figures["median_error_m"] < 0.04 and figures["repeatability_m"] < 0.03
    assert figures["analytic_median_error_m"] > 0 and 0 < figures["release_tracking_error_mm"] < 50
    assert figures["real_time_factor"] > 1 and figures["calibration_loo_m"] > 0


def test_the_world_flags_are_refused_in_the_kinematic_world(capsys):
    assert main(["bench", "throwing", "--quick", "--world", "kinematic", "--release-latency-ms", "20"]) == 2
    assert "set the MuJoCo world" in capsys.readouterr().err
    assert main(["bench", "tracking", "--world", "mujoco"]) == 2
    assert "options of `bench throwing`" in capsys.readouterr().err
