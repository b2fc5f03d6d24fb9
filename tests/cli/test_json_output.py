"""Every `--json` output is exactly one strict JSON document on stdout: no banner, no NaN.

`bench dashboard --json` printed viser's banner before its JSON; `calibrate --robot --points 6
--json` a bare NaN. The commands' other --json runs are parsed the same way where they are tested
(test_calibrate, test_calibrate_robot, test_throw, test_track, test_bench_throwing)."""

import pytest

from tests.helpers.strict_json import loads_strict
from wiithrow.app.cli import json_output
from wiithrow.app.cli.main import main


@pytest.mark.parametrize(
    "argv",
    [
        ["calibrate", "--demo", "--json"],
        ["devices", "--json"],
        ["bench", "calibration", "--quick", "--json"],
    ],
    ids=lambda argv: " ".join(argv[:2]),
)
def test_one_strict_document(capsys, argv):
    assert main(argv) in (0, 2)
    document = loads_strict(capsys.readouterr().out)
    assert isinstance(document, dict) and document


def test_calibrate_from_a_file(tmp_path, capsys):
    from tests.cli.test_calibrate import write_calibration_points
    from wiithrow.vision.rig import observe_all, points_in_common_view, stereo_rig

    cams = stereo_rig()
    rng = __import__("numpy").random.default_rng(0)
    X = points_in_common_view(cams, 30, rng)
    write_calibration_points(tmp_path / "p.csv", X, observe_all(cams, X, rng))
    argv = ["calibrate", "--points", str(tmp_path / "p.csv"), "--out", str(tmp_path / "c.json"), "--json"]
    assert main(argv) == 0
    assert loads_strict(capsys.readouterr().out)["loo_error_m"] < 0.006


def test_train(tmp_path, capsys, monkeypatch, sim_world):
    from tests.helpers.shipped_run import shipped_run
    from wiithrow.app.cli.commands import train

    monkeypatch.setattr(train, "throw_the_run", lambda session, *args, **kwargs: shipped_run(session))
    cal = sim_world.true_calibration().save(tmp_path / "cal.json")
    assert (
        main(
            [
                "train",
                "--sim",
                "--world",
                "kinematic",
                "--calibration",
                str(cal),
                "--out",
                str(tmp_path / "l.json"),
                "--json",
            ]
        )
        == 0
    )
    assert loads_strict(capsys.readouterr().out)["throws"] == 25


@pytest.mark.slow
def test_bench_dashboard_prints_no_banner_on_stdout(capsys):
    assert main(["bench", "dashboard", "--quick", "--json"]) == 0
    captured = capsys.readouterr()
    figures = loads_strict(captured.out)
    assert figures["clients_1"]["updates"] > 0
    assert "viser" not in captured.out + captured.err  # its banner is silenced (web/handshake.py), not moved


def test_whatever_else_a_json_command_prints_goes_to_stderr(capsys):
    with json_output.json_mode():
        print("a library's banner")
        json_output.emit({"a": float("nan"), "b": [1.0, float("inf")]})
        with pytest.raises(RuntimeError, match="second JSON document"):
            json_output.emit({})
    captured = capsys.readouterr()
    assert loads_strict(captured.out) == {"a": None, "b": [1.0, None]}
    assert captured.err == "a library's banner\n"
