"""`wiithrow bench following`: an arm following a throw on a PD servo with each feed-forward, one JSON
document; `--sim-clock` only where it means something."""

from __future__ import annotations

from pathlib import Path

from tests.helpers.strict_json import loads_strict
from wiithrow.app.cli.main import main

LAB = Path(__file__).resolve().parents[1] / "data" / "foreign_worlds" / "panda_pd" / "settings.json"


def test_bench_following_gives_each_feedforwards_lag_on_a_labs_pd_arm(capsys):
    assert main(["bench", "following", "--settings", str(LAB), "--json"]) == 0
    figures = loads_strict(capsys.readouterr().out)
    assert figures["servo"] == "position"
    assert figures["none"]["lag_s"] > 0.08 > 0.002 > abs(figures["inverse_dynamics"]["lag_s"])
    assert figures["velocity"]["rms_rad"] < figures["none"]["rms_rad"] / 5


def test_sim_clock_is_for_the_hardware_paths_throwing_bench_only(capsys):
    assert main(["bench", "following", "--sim-clock"]) == 2
    assert "--sim-clock is for `wiithrow bench throwing --settings S.json` only" in capsys.readouterr().err
    assert main(["bench", "throwing", "--sim-clock", "--quick"]) == 2
