"""`wiithrow track` and `wiithrow bench tracking` as a user runs them."""

import csv
import json

import pytest

from tests.helpers.strict_json import loads_strict
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
    figures = loads_strict(capsys.readouterr().out)
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


@pytest.fixture()
def true_calibration(sim_world, tmp_path):
    """The simulated rig's true cameras as a calibration file, with a way to edit it."""

    def make(change=None, name="cal.json"):
        path = sim_world.true_calibration().save(tmp_path / name)
        if change is not None:
            document = json.loads(path.read_text())
            change(document)
            path.write_text(json.dumps(document))
        return str(path)

    return make


def test_the_calibrations_frame_is_honoured(capsys, true_calibration):
    """A `"frame": "base"` calibration gave rows labelled link1."""
    cal = true_calibration(lambda d: d.update(frame="base"))
    assert main(["track", "--sim", "--duration", "0.2", "--calibration", cal]) == 0
    rows = [json.loads(line) for line in capsys.readouterr().out.splitlines()]
    assert rows and {r["frame"] for r in rows} == {"base"}


@pytest.mark.parametrize(
    "change, needle",
    [
        (lambda d: d["cameras"][0].update(P=[[0.0] * 4] * 3), "cam0: its projection matrix is degenerate"),
        (lambda d: d["cameras"][1].update(P=d["cameras"][0]["P"]), "same centre"),
    ],
)
def test_a_broken_calibration_is_one_line(capsys, true_calibration, change, needle):
    assert main(["track", "--sim", "--duration", "0.2", "--calibration", true_calibration(change)]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("wiithrow track: ") and len(err.splitlines()) == 1 and needle in err, err


@pytest.mark.parametrize("target", [lambda d: d / "afile" / "m.csv", lambda d: d, lambda d: "/sys/m.csv"])
def test_unwritable_out_is_refused_before_tracking(tmp_path, capsys, monkeypatch, target):
    from wiithrow.app.cli.commands import track

    (tmp_path / "afile").write_text("x")
    monkeypatch.setattr(track, "_simulated", lambda *a: pytest.fail("tracked before checking --out"))
    assert main(["track", "--sim", "--duration", "0.2", "--out", str(target(tmp_path))]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("wiithrow track: cannot write") and len(err.splitlines()) == 1, err
    assert [p.name for p in tmp_path.iterdir()] == ["afile"]


def test_realtime_t_counts_from_the_start(capsys):
    """`--realtime` gave t on the machine's uptime clock."""
    assert main(["track", "--sim", "--realtime", "--duration", "0.3"]) == 0
    t = [json.loads(line)["t"] for line in capsys.readouterr().out.splitlines()]
    assert t and 0.0 <= min(t) < 0.15 and max(t) <= 0.35


def test_ctrl_c_keeps_the_rows_tracked_so_far(tmp_path, capsys, monkeypatch):
    from wiithrow.app.rig.stream import RigStream

    polls = []
    real_poll = RigStream.poll

    def poll(self, *args, **kwargs):
        polls.append(1)
        if len(polls) == 200:
            raise KeyboardInterrupt
        return real_poll(self, *args, **kwargs)

    monkeypatch.setattr(RigStream, "poll", poll)
    out = tmp_path / "m.csv"
    assert main(["track", "--sim", "--duration", "5", "--format", "csv", "--out", str(out)]) == 130
    rows = list(csv.DictReader(out.open()))
    assert rows and all(len(r) == 8 and r["views"] for r in rows)
    assert "interrupted" in capsys.readouterr().err
    assert [p.name for p in tmp_path.iterdir()] == ["m.csv"]


def test_simulation_flags_need_the_simulated_rig(capsys, monkeypatch):
    from wiithrow.app.cli.commands import track

    monkeypatch.setattr(track, "_remotes_present", lambda: True)
    assert main(["track", "--speed", "1.0", "--calibration", "x.json"]) == 2
    err = capsys.readouterr().err
    assert "--speed does not apply" in err and "Traceback" not in err
