"""`wiithrow track` and `wiithrow bench tracking` as a user runs them."""

import csv
import json

from wiithrow.app.cli.main import main


def test_track_simulated_rig_writes_json_lines(capsys):
    assert main(["track", "--sim", "--duration", "0.5"]) == 0
    rows = [json.loads(line) for line in capsys.readouterr().out.splitlines()]
    assert {r["id"] for r in rows} == {0, 1, 2, 3}
    assert all(r["frame"] == "link1" and set(r) >= {"id", "t", "x", "y", "z"} for r in rows)
    assert min(r["x"] for r in rows) > 0.7 and max(r["x"] for r in rows) < 1.1


def test_track_csv_to_a_file(tmp_path):
    out = tmp_path / "markers.csv"
    assert main(["track", "--sim", "--duration", "0.3", "--format", "csv", "--out", str(out)]) == 0
    rows = list(csv.DictReader(out.open()))
    assert rows and set(rows[0]) == {"id", "t", "x", "y", "z", "frame", "visible", "views"}


def test_track_bad_duration(capsys):
    assert main(["track", "--sim", "--duration", "0"]) == 2
    assert "--duration" in capsys.readouterr().err


def test_bench_tracking_quick_reports_its_figures(capsys):
    assert main(["bench", "tracking", "--quick", "--json"]) == 0
    figures = json.loads(capsys.readouterr().out)
    assert figures["stereo_frames"] == 500 and 3.9 < figures["markers_per_frame"] <= 4
    assert figures["frames_per_s"] > 0 and 0 < figures["p50_ms"] <= figures["p99_ms"]
