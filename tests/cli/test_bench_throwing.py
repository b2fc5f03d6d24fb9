"""`wiithrow bench throwing --quick` runs the whole pipeline and reports every figure."""

from tests.helpers.strict_json import loads_strict
from wiithrow.app.cli.main import main


def test_bench_throwing_quick(capsys):
    assert main(["bench", "throwing", "--quick", "--json"]) == 0
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
