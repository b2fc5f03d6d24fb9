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
    assert set(figures) == {"remotes_2", "remotes_4"}
    for rig in figures.values():
        assert rig["synced_frames"] == 500 and 3.9 < rig["markers_per_frame"] <= 4
        assert rig["frames_per_s"] > 0 and 0 < rig["p50_ms"] <= rig["p99_ms"]


def test_track_with_four_simulated_remotes(capsys):
    assert main(["track", "--sim", "--cameras", "4", "--duration", "0.5"]) == 0
    rows = [json.loads(line) for line in capsys.readouterr().out.splitlines()]
    assert {r["id"] for r in rows} == {0, 1, 2, 3} and max(r["views"] for r in rows) == 4


def test_track_sizes_the_simulated_rig_by_the_calibration(tmp_path, capsys):
    """Issue 15: a 3-camera calibration used to fail with 'the simulated rig 2'."""
    from wiithrow.app.settings import Settings
    from wiithrow.app.worlds import SimWorld

    path = SimWorld(Settings().with_cameras(3)).true_calibration().save(tmp_path / "three.json")
    assert main(["track", "--sim", "--calibration", str(path), "--duration", "0.5"]) == 0
    rows = [json.loads(line) for line in capsys.readouterr().out.splitlines()]
    assert {r["id"] for r in rows} == {0, 1, 2, 3} and max(r["views"] for r in rows) == 3
    assert main(["track", "--sim", "--calibration", str(path), "--cameras", "2", "--duration", "0.5"]) == 2
    assert "the calibration has 3 cameras, --cameras 2" in capsys.readouterr().err
