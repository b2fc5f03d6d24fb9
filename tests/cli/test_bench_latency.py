"""`wiithrow bench latency`: the JSON a user gets from a short run measures every stage and every
consumer (counts > 0, p50 <= p99 <= max), with and without the dashboard and the recorder. The
figures themselves depend on the machine's load: they are the benchmark's, not the suite's."""

from __future__ import annotations

import json
import time

import numpy as np
import pytest

from wiithrow.app.cli.bench.wake_probe import WakeProbe, percentile
from wiithrow.app.cli.main import main
from wiithrow.app.rig.stage_stamps import StageStamps
from wiithrow.clock import SimClock

STAGES = {"decoded", "synced", "tracked"}


def _measured(summary: dict, what: str) -> None:
    assert summary["count"] > 0, f"{what} was never measured"
    assert 0.0 <= summary["p50_ms"] <= summary["p99_ms"] <= summary["max_ms"], f"{what}: {summary}"


@pytest.mark.slow
def test_a_short_run_measures_every_stage_and_consumer(capsys):
    assert main(["bench", "latency", "--seconds", "2", "--json"]) == 0
    figures = json.loads(capsys.readouterr().out)
    assert figures["seconds"] == 2.0 and figures["remotes"] == 2
    configurations = {
        "bare": {"publisher", "session"},
        "dashboard_recorder": {"recorder", "publisher", "session", "dashboard"},
    }
    for name, consumers in configurations.items():
        run = figures[name]
        assert set(run["stages"]) == STAGES
        assert set(run["consumers"]) == consumers
        for stage, summary in run["stages"].items():
            _measured(summary, f"{name}: stage {stage}")
        for consumer, summary in run["consumers"].items():
            _measured(summary, f"{name}: consumer {consumer}")
        assert isinstance(run["deliveries_without_stamps"], int)  # frames a flush tracked carry no stamps
        # Each frame is put once: a repeated put stamp was the writer process reading its ring again
        # from record 0 (a write count read as 0 while struct zeroed it: `frame_ring`), 170 in a CI run
        assert run["publisher_stamps_repeated"] == 0, f"{name}: frames put twice"
        assert run["consumers"]["publisher"]["count"] <= run["stages"]["tracked"]["count"]
        stages = run["stages"]
        assert stages["decoded"]["p50_ms"] <= stages["tracked"]["p50_ms"]  # stamps are in order, per frame
        expected = max(s["p99_ms"] for c, s in run["consumers"].items() if c != "dashboard")
        assert run["report_to_consumer_p99_ms"] == expected
        # the machine's floor over the same seconds (its count per deadline: the probe's own test below)
        _measured(run["machine_wake"], f"{name}: machine wake")
        # the collector's passes over the same seconds, per generation (a short run may have none)
        assert set(run["gc_pauses"]) == {"0", "1", "2"}
        for generation, pauses in run["gc_pauses"].items():
            assert pauses["count"] >= 0, generation
            assert 0.0 <= pauses["p50_ms"] <= pauses["max_ms"] <= pauses["total_ms"] + 1e-9, f"{generation}: {pauses}"
    assert figures["meets_goal"] == (
        figures["dashboard_recorder"]["report_to_consumer_p99_ms"] <= figures["goal_p99_ms"]
    )


def test_seconds_is_checked_in_one_line(capsys):
    assert main(["bench", "tracking", "--seconds", "2"]) == 2
    assert "--seconds is for `wiithrow bench ros2` and `wiithrow bench latency` only" in capsys.readouterr().err
    assert main(["bench", "latency", "--seconds", "0"]) == 2
    assert "--seconds must be > 0, got 0" in capsys.readouterr().err


def test_stage_stamps_keep_the_latest_frames_and_measure_from_the_read():
    clock = SimClock(10.0)
    stamps = StageStamps(clock, capacity=2)
    for k in range(3):
        t = 0.01 * k
        stamps.frame(t, read=1.0 + t, decoded=1.0001 + t, synced=1.0002 + t, tracked=1.0003 + t)
    assert stamps.stages(0.0) is None  # the oldest of three, beyond the capacity of 2
    assert stamps.stages(0.02) == pytest.approx((1.02, 1.0201, 1.0202, 1.0203))
    assert stamps.since_read["tracked"] == pytest.approx([0.0003] * 3)
    stamps.delivered("publisher", 0.02, now=1.025)
    stamps.delivered("publisher", 0.0, now=1.03)  # forgotten: counted, not measured
    assert stamps.delivered_after["publisher"] == pytest.approx([0.005])
    assert stamps.unknown_deliveries == 1
    stamps.restart()
    assert stamps.since_read["tracked"] == [] and stamps.delivered_after == {}


def test_the_wake_probe_counts_its_deadlines_and_how_late_it_woke():
    probe = WakeProbe()
    try:
        start = time.monotonic()  # (before `begin`: the probe's seconds lie within start..end)
        probe.begin()
        time.sleep(0.5)
        figures = probe.end()
        elapsed = time.monotonic() - start
    finally:
        probe.close()
    # one wake per 1 ms deadline at most (missed deadlines are skipped, not caught up) over the
    # seconds it measured, which lie between `start` and `end`'s return; a wake is never early
    assert 0 < figures["count"] <= 1000 * elapsed + 1
    assert 0.0 <= figures["p50_ms"] <= figures["p99_ms"] <= figures["max_ms"]


def test_the_wake_probe_percentiles_are_numpys():
    rng = np.random.default_rng(3)
    for n in (1, 2, 7, 1000):
        values = sorted(rng.exponential(0.2, size=n).tolist())
        for q in (0, 50, 99, 100):
            assert percentile(values, q) == pytest.approx(float(np.percentile(values, q)), rel=1e-12, abs=1e-15)
