"""The user's path in the MuJoCo world, through the commands (issue 21): `train --sim --world mujoco`
(the robot calibration of the simulated rig, then 25 rig-labelled throws) and `throw --sim --world
mujoco --library ... --yes` at the demo's target and at five more over the trained area. Each throw
is a fresh command, as a user runs it; the true errors meet the benchmark's goals: the demo's target
within 15 mm, every target within 30 mm (the p95 goal), their median within 15 mm."""

import numpy as np
import pytest

from tests.helpers.strict_json import loads_strict
from wiithrow.app.cli.main import main
from wiithrow.app.session.simulated import demo_target_base

#: The demo's target, then five more (base, m) spread over the trained area (distance 1.0-1.6 m,
#: height 0-0.4 m) at azimuths on both sides.
TARGETS = [
    demo_target_base(),
    np.array([1.05, 0.0, 0.05]),
    np.array([1.5, 0.1, 0.35]),
    np.array([1.2, -0.3, 0.3]),
    np.array([1.55, -0.2, 0.1]),
    np.array([1.1, 0.25, 0.25]),
]


@pytest.mark.slow
def test_the_users_path_in_mujoco_meets_the_benchmarks_goals(tmp_path, capsys):
    library = tmp_path / "lib.json"
    assert main(["train", "--sim", "--world", "mujoco", "--out", str(library), "--json"]) == 0
    trained = loads_strict(capsys.readouterr().out)
    assert trained["throws"] == 25
    # both held-out figures are reported: the regression's own (measured median 8.1 mm, its edges
    # extrapolate) and the model mismatch (5.2 mm)
    assert 0 < trained["regression_loo_median_m"] < 0.02 and trained["model_mismatch_median_m"] > 0
    errors = []
    for target in TARGETS:
        argv = ["throw", "--sim", "--world", "mujoco", "--library", str(library), "--yes", "--json", "--target"]
        assert main([*argv, *(f"{v:.4f}" for v in target)]) == 0
        result = loads_strict(capsys.readouterr().out)["result"]
        assert result["failure"] is None
        errors.append(result["true_error_m"])
    errors_m = np.array(errors)
    assert errors_m[0] <= 0.015, errors_m  # the demo's target
    assert errors_m.max() <= 0.030, errors_m
    assert np.median(errors_m) <= 0.015, errors_m
