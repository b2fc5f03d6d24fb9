"""Files and outputs that go wrong, as a user meets them on the command line (issue 20, "Files"):
nested JSON, NaN in a calibration or settings file, a disk that fills up while rows stream out.
Each is exit status 2 and one line naming the file and what is wrong, never a traceback, and
nothing already written is lost."""

from __future__ import annotations

import csv
import json
import subprocess
import sys

import pytest

from tests.helpers.command_lines import after_opening
from tests.helpers.full_disk import fill_after
from wiithrow.app.cli.main import main

NESTED = "[" * 5000 + "]" * 5000


def _one_line(err: str) -> str:
    lines = after_opening(err.strip().splitlines())  # the error is the one line after the run's opening
    assert len(lines) == 1 and "Traceback" not in err, err
    return lines[0]


@pytest.fixture(scope="module")
def calibration_text():
    from wiithrow.app.worlds import SimWorld

    return SimWorld(seed=0).true_calibration().to_text()


def _edited(text, change):
    document = json.loads(text)
    change(document)
    return json.dumps(document)  # NaN and infinities as the NaN and Infinity tokens


@pytest.mark.parametrize(
    "change, needle",
    [
        (
            lambda d: d["cameras"][1].update(K=[[float("nan"), 0, 0], [0, 1, 0], [0, 0, 1]]),
            "camera 1 (cam1): K[0][0] is NaN",
        ),
        (
            lambda d: d["cameras"][0].update(rms_px=float("nan")),
            "camera 0 (cam0): rms_px is NaN or infinite: every number in a calibration must be finite",
        ),
        (lambda d: d.update(loo_error_m=float("inf")), "loo_error_m is NaN or infinite"),
        (lambda d: d["cameras"][0]["P"][1].__setitem__(3, float("-inf")), "camera 0 (cam0): P[1][3] is -inf"),
        (lambda d: d.update(meta={"deep": json.loads("[" * 40 + "]" * 40)}), "nested deeper than 32 levels"),
    ],
)
@pytest.mark.parametrize("command", [["track", "--sim", "--duration", "0.1"], ["triangulate", "--points", "p.csv"]])
def test_a_bad_calibration_is_one_line_naming_camera_and_field(
    tmp_path, capsys, calibration_text, change, needle, command
):
    path = tmp_path / "cal.json"
    path.write_text(_edited(calibration_text, change))
    (tmp_path / "p.csv").write_text("u0,v0,u1,v1\n500,400,510,400\n")
    before = path.read_bytes()
    assert main([*command, "--calibration", str(path)]) == 2
    line = _one_line(capsys.readouterr().err)
    assert line.startswith(f"wiithrow {command[0]}: {path}: ") and needle in line, line
    assert path.read_bytes() == before


def test_a_deeply_nested_calibration_is_one_line(tmp_path, capsys):
    path = tmp_path / "cal.json"
    path.write_text('{"kind": "wiithrow.calibration", "schema": 1, "cameras": ' + NESTED + "}")
    assert main(["track", "--sim", "--duration", "0.1", "--calibration", str(path)]) == 2
    assert _one_line(capsys.readouterr().err) == (
        f"wiithrow track: {path}: nested deeper than 32 levels (arrays or objects inside each other), which no "
        "wiithrow file or message is; the file is corrupt: restore it or write a new one"
    )


@pytest.mark.parametrize(
    "settings, needle",
    [
        ('{"rig": {"baseline": NaN}}', "rig.baseline must be a number from 0.01 to 2 m, got nan"),
        ('{"rig": {"baseline": 1e999}}', "rig.baseline must be a number from 0.01 to 2 m, got inf"),
        ('{"ball": {"mass_kg": -Infinity}}', "ball.mass_kg must be a number from 0.001 to 10 kg, got -inf"),
        ('{"rig": {"count": 3.5}}', "rig.count must be a whole number from 2 to 4, got 3.5"),
        (
            '{"mujoco": {"target_base": [1, 0, NaN]}}',
            "mujoco.target_base[2] must be a number from -10 to 10 m, got nan",
        ),
        (NESTED, "nested deeper than 32 levels"),
    ],
)
def test_a_bad_settings_file_is_one_line_naming_the_key(tmp_path, capsys, settings, needle):
    path = tmp_path / "settings.json"
    path.write_text('{"kind": "wiithrow.settings", "schema": 1, "settings": ' + settings + "}")
    assert main(["serve", "--settings", str(path), "--duration", "0.1", "--port", "0"]) == 2
    line = _one_line(capsys.readouterr().err)
    assert line.startswith(f"wiithrow serve: {path}: ") and needle in line, line


def test_a_nested_throw_library_is_one_line(tmp_path, capsys):
    path = tmp_path / "lib.json"
    path.write_text('{"kind": "wiithrow.throw_library", "schema": 1, "meta": ' + NESTED + "}")
    assert (
        main(
            ["throw", "--sim", "--world", "kinematic", "--target", "1.3", "0", "0", "--dry-run", "--library", str(path)]
        )
        == 2
    )
    line = _one_line(capsys.readouterr().err)
    assert line == (
        f"wiithrow throw: {path}: nested deeper than 32 levels (arrays or objects inside each other), which no "
        "wiithrow file or message is; restore the throw library or train a new one"
    )


# -- a disk that fills up while track streams rows -----------------------------------------------


@pytest.mark.parametrize("fmt", ["jsonl", "csv"])
def test_track_out_on_a_full_disk_keeps_the_rows_written_and_says_so(tmp_path, capsys, monkeypatch, fmt):
    """The disk has 20 kB free: track stops there, exit 2, one line; every complete row written
    before stays in --out (it was all lost, with an OSError traceback)."""
    fill_after(monkeypatch, 20_000)
    out = tmp_path / f"rows.{fmt}"
    assert main(["track", "--sim", "--duration", "5", "--format", fmt, "--out", str(out)]) == 2
    line = _one_line(capsys.readouterr().err)
    lines = out.read_text().splitlines()
    assert line == (
        f"wiithrow track: cannot write more to {out} (No space left on device): the {len(lines)} complete lines "
        "written until then are kept in it"
    )
    assert 19_000 < out.stat().st_size <= 20_000 and out.read_text().endswith("\n")
    if fmt == "csv":
        rows = list(csv.DictReader(out.open()))
        assert len(rows) == len(lines) - 1 and all(len(r) == 8 and None not in r.values() for r in rows)
    else:
        rows = [json.loads(row) for row in lines]
        assert {r["id"] for r in rows} == {0, 1, 2, 3}
    times = [float(r["t"]) for r in rows]
    assert times == sorted(times) and times[-1] > 0.2
    assert [p.name for p in tmp_path.iterdir()] == [out.name]


class _FullStdout:
    """Standard output redirected to a disk with `capacity` characters free."""

    def __init__(self, capacity: int) -> None:
        self.text = ""
        self.room = capacity

    def write(self, text: str) -> int:
        import errno
        import os

        taken = text[: self.room]
        self.text += taken
        self.room -= len(taken)
        if len(taken) < len(text):
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))
        return len(text)

    def flush(self) -> None:
        pass


def test_track_to_a_full_standard_output_says_how_many_rows_went_out(capsys, monkeypatch):
    full = _FullStdout(10_000)
    monkeypatch.setattr(sys, "stdout", full)
    assert main(["track", "--sim", "--duration", "5"]) == 2
    line = _one_line(capsys.readouterr().err)
    complete = full.text.splitlines()[:-1] if not full.text.endswith("\n") else full.text.splitlines()
    said = int(line.split("the ")[1].split(" rows")[0])
    assert (
        line
        == f"wiithrow track: cannot write more to standard output (No space left on device): the {said} rows before it were written"
    )
    assert 0 < said <= len(complete) <= said + 4  # at most the failing frame's four markers more
    assert all(json.loads(row)["frame"] == "link1" for row in complete)


def test_track_to_dev_full_is_one_line_and_exit_2():
    """A real ENOSPC: standard output on /dev/full; no traceback at exit either (the unwritten
    buffer would be flushed again)."""
    with open("/dev/full", "w") as full:
        done = subprocess.run(
            [sys.executable, "-c", "import sys; from wiithrow.app.cli.main import main; sys.exit(main(sys.argv[1:]))"]
            + ["track", "--sim", "--duration", "0.5"],
            stdout=full,
            stderr=subprocess.PIPE,
            text=True,
            timeout=120,
        )
    assert done.returncode == 2
    assert _one_line(done.stderr) == (
        "wiithrow track: cannot write more to standard output (No space left on device): the 0 rows before it were written"
    )


def test_listen_to_a_full_standard_output_is_one_line(capsys, monkeypatch):
    """listen streams one JSON line per sample: a full disk behind its stdout ends it in one line
    (the Zenoh session replaced by samples given here, one of them nested too deep to read)."""
    from wiithrow.app.cli.commands import listen
    from wiithrow.app.network.subscriber import Received

    samples = [Received("wiithrow/rig/markers", b'{"seq": %d}' % i, 1.0 + i) for i in range(200)]
    samples[3] = Received("wiithrow/rig/markers", NESTED.encode(), 4.0)

    class Session:
        def close(self):
            pass

    class Subscription:
        def __init__(self, session, keyexpr):
            pass

        def get(self, timeout_s=None):
            return samples.pop(0) if samples else None

        def close(self):
            pass

    monkeypatch.setattr(listen, "open_zenoh", lambda args: Session())
    monkeypatch.setattr(listen, "Subscription", Subscription)
    full = _FullStdout(20_000)
    monkeypatch.setattr(sys, "stdout", full)
    assert main(["listen", "--count", "200"]) == 2
    line = _one_line(capsys.readouterr().err)
    rows = full.text.splitlines()[:-1]
    assert line == (
        f"wiithrow listen: cannot write more to standard output (No space left on device): the {len(rows)} rows "
        "before it were written"
    )
    assert json.loads(rows[3])["payload"] == NESTED and [json.loads(r)["payload"]["seq"] for r in rows[4:6]] == [4, 5]


def test_replay_out_on_a_full_disk_keeps_the_rows_written_and_says_so(tmp_path, capsys, monkeypatch):
    """The other command that streams rows to a file: the same `StagedFile`, the same line."""
    record, live = tmp_path / "run.mcap", tmp_path / "live.jsonl"
    assert main(["track", "--sim", "--duration", "1", "--record", str(record), "--out", str(live)]) == 0
    live_rows = live.read_text().splitlines()
    fill_after(monkeypatch, 10_000)
    out = tmp_path / "rows.jsonl"
    assert main(["replay", str(record), "--out", str(out)]) == 2
    line = _one_line(capsys.readouterr().err)
    kept = out.read_text().splitlines()
    assert line == (
        f"wiithrow replay: cannot write more to {out} (No space left on device): the {len(kept)} complete lines "
        "written until then are kept in it"
    )
    assert 50 < len(kept) < len(live_rows)
    strip_t = [{k: v for k, v in json.loads(r).items() if k != "t"} for r in kept]
    assert strip_t == [{k: v for k, v in json.loads(r).items() if k != "t"} for r in live_rows[: len(kept)]]


def test_a_whole_output_file_on_a_full_disk_is_one_line_and_leaves_the_old_one(
    tmp_path, capsys, monkeypatch, calibration_text
):
    """Outputs written at the end (triangulate, calibrate, train: `files.write_temp_beside`)."""
    import errno
    import os

    from wiithrow.vision import files

    (tmp_path / "cal.json").write_text(calibration_text)
    (tmp_path / "p.csv").write_text("u0,v0,u1,v1\n500,400,510,400\n")
    out = tmp_path / "xyz.csv"
    out.write_text("the old points\n")

    def full(fd):
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))

    monkeypatch.setattr(files.os, "fsync", full)
    argv = ["triangulate", "--calibration", str(tmp_path / "cal.json"), "--points", str(tmp_path / "p.csv")]
    assert main([*argv, "--out", str(out)]) == 2
    assert _one_line(capsys.readouterr().err) == (
        f"wiithrow triangulate: cannot write {out} (No space left on device): nothing was written; the file there "
        "is as it was"
    )
    assert out.read_text() == "the old points\n" and sorted(p.name for p in tmp_path.iterdir()) == [
        "cal.json",
        "p.csv",
        "xyz.csv",
    ]
