"""`wiithrow bench wand --quick`: a wand calibration against the robot's, with 2 and 4 remotes."""

import json

import pytest

from wiithrow.app.cli.main import main


@pytest.mark.slow
def test_bench_wand_quick_reports_every_figure(capsys):
    assert main(["bench", "wand", "--quick", "--json"]) == 0
    figures = json.loads(capsys.readouterr().out)
    assert set(figures) == {"remotes_2", "remotes_4"}
    for remotes, rig in zip((2, 4), figures.values()):
        # 10 s of waving against 8 robot poses: measured ratio 0.99 and 0.96
        assert rig["ratio_to_robot"] <= 1.25
        assert rig["wand_test_error_mm"] <= 1.1 * rig["true_cameras_test_error_mm"]
        assert len(rig["reprojection_rms_px"]) == remotes and max(rig["reprojection_rms_px"]) < 1.5
        # the wand score is the rig's: the true cameras' own score on the same frames
        assert rig["wand_score_percent"] == pytest.approx(rig["true_cameras_wand_score_percent"], rel=0.1)
        assert rig["fit_s"] > 0 and rig["frames"]["fitted"] <= 1000
