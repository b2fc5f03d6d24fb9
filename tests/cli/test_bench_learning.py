"""`wiithrow bench learning`: registered, its world flag only `--world`, its refit timing measured
at the size bound (the whole drift run is `--quick`, marked slow: about 40 throws)."""

import numpy as np
import pytest

from tests.helpers.strict_json import loads_strict
from wiithrow.app.cli.bench.learning import refit_times
from wiithrow.app.cli.main import main
from wiithrow.app.throws.library_file import load_library


def test_refit_times_at_the_bound():
    times = refit_times(load_library(), np.random.default_rng(0), size=40)
    assert times.shape == (40, 2) and np.all(times > 0) and np.isfinite(times).all()


def test_only_the_world_is_a_flag_of_bench_learning(capsys):
    assert main(["bench", "learning", "--release-latency-ms", "20"]) == 2
    assert "--world also of `bench learning`" in capsys.readouterr().err


@pytest.mark.slow
def test_bench_learning_quick(capsys):
    assert main(["bench", "learning", "--quick", "--json"]) == 0
    figures = loads_strict(capsys.readouterr().out)
    assert figures["world"] == "kinematic" and figures["measured_throws_joined"] == 10
    assert figures["drift"]["release_latency_ms_after"] == pytest.approx(15.0)
    # 6 probes: the drift raises the median; 10 measured throws bring it back within the goal
    assert figures["after_drift_median_error_m"] > figures["before_drift_median_error_m"]
    assert figures["recovered_within_10_mm"] and figures["refit_p99_ms"] > 0
