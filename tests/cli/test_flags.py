"""Flags: a bad value is one line and exit status 2 before anything runs; numbers parse as numbers."""

import pytest

from wiithrow.app.cli.main import build_parser, main

SEEDED = [
    ["track", "--sim", "--duration", "0.1"],
    ["calibrate", "--demo"],
    ["calibrate", "--robot", "--sim", "--world", "kinematic", "--points", "6"],
    ["train", "--sim", "--world", "kinematic"],
    ["throw", "--target", "1.3", "0", "0", "--sim", "--world", "kinematic", "--dry-run"],
    ["reproduce", "--out", "never"],
    ["demo", "--duration", "0.1"],
]


def one_line_exit_2(capsys, argv, *needles):
    assert main(argv) == 2
    captured = capsys.readouterr()
    lines = captured.err.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in captured.err, captured.err
    assert lines[0].startswith("wiithrow"), lines[0]
    for needle in needles:
        assert needle in lines[0], lines[0]
    return lines[0]


@pytest.mark.parametrize("argv", SEEDED, ids=lambda a: a[0])
@pytest.mark.parametrize("seed", ["-1", "2.5", "9223372036854775808"])
def test_a_bad_seed_is_refused_by_every_command(capsys, tmp_path, monkeypatch, argv, seed):
    monkeypatch.chdir(tmp_path)
    one_line_exit_2(capsys, [*argv, "--seed", seed], f"wiithrow {argv[0]}:", "seed")
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize(
    "argv, needle",
    [
        (["track", "--sim", "--duration", "nan"], "--duration: must be a finite number above 0"),
        (["track", "--sim", "--duration", "-1"], "--duration"),
        (["track", "--sim", "--duration", "inf"], "--duration"),
        (["track", "--sim", "--speed", "nan"], "--speed: must be a finite number above 0"),
        (["throw", "--target", "-inf", "0", "0", "--sim"], "--target: must be a finite number, got '-inf'"),
        (["throw", "--target", "1.3", "nan", "0", "--sim"], "--target: must be a finite number"),
        (["throw", "--target", "1.3", "0", "0", "--sim", "--margin", "-0.1"], "--margin"),
        (["demo", "--port", "70000"], "--port"),
        (["demo", "--poses", "0"], "--poses"),
        (
            ["demo", "--poses", "6", "--duration", "0.1", "--no-calibrate"],
            "--poses: the dashboard calibrates with 7 to 100",
        ),
        (["serve", "--poses", "101", "--duration", "0.1"], "--poses: the dashboard calibrates with 7 to 100"),
        (
            ["calibrate", "--demo", "--bogus"],
            "wiithrow calibrate: unknown flag --bogus (see `wiithrow calibrate --help`)",
        ),
        (["calibrate", "--method", "magic", "--points", "x.csv"], "invalid choice: 'magic'"),
    ],
)
def test_bad_values_are_one_line_before_anything_runs(capsys, argv, needle):
    one_line_exit_2(capsys, argv, needle)


def test_negative_numbers_in_every_spelling_are_values():
    args = build_parser().parse_args(["throw", "--target", "1.2", "-1e-1", "-.5", "--sim"])
    assert args.target == [1.2, -0.1, -0.5]


def test_help_is_exit_0(capsys):
    assert main(["track", "--help"]) == 0
    assert "--duration" in capsys.readouterr().out


def test_running_out_of_memory_is_one_line(capsys, monkeypatch):
    """4 million rows ended in a MemoryError traceback after 26 s (the solve now needs O(N) memory,
    but a large enough file still fills a machine)."""
    from wiithrow.app.cli.commands import calibrate

    def too_big(*args, **kwargs):
        raise MemoryError

    monkeypatch.setattr(calibrate, "read_calibration_points", too_big)
    one_line_exit_2(capsys, ["calibrate", "--points", "huge.csv", "--out", "/tmp/never.json"], "out of memory")


@pytest.mark.parametrize(
    "argv",
    [
        ["train", "--sim"],
        ["throw", "--sim", "--target", "1.3", "0", "0.2"],
        ["calibrate", "--robot", "--sim"],
        ["calibrate", "--wand", "--sim"],
        ["demo"],
    ],
    ids=lambda a: " ".join(a[:2]),
)
def test_every_simulated_command_defaults_to_the_mujoco_world(argv):
    """Issue 21: one world by default everywhere, the demo's (reproduce keeps the kinematic one: its
    docstring says why)."""
    from wiithrow.app.cli.world_choice import sim_world_line, sim_world_name

    args = build_parser().parse_args(argv)
    assert sim_world_name(args) == "mujoco" and sim_world_line(sim_world_name(args)) == "world: MuJoCo (simulated)"
    assert build_parser().parse_args(["reproduce", "--out", "x"]).world == "kinematic"


def test_the_commands_and_the_dashboard_name_the_world_alike():
    """A command's first line ("world: ...") and the dashboard's "World: ..." line use the same words."""
    from wiithrow.app.cli.world_choice import WORLD_NAMES
    from wiithrow.app.worlds.mujoco.world import MujocoWorld
    from wiithrow.app.worlds.simulated import SimWorld

    assert {"mujoco": MujocoWorld.title, "kinematic": SimWorld.title} == WORLD_NAMES
