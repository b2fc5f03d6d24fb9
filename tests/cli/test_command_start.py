"""`main` builds the parser of the command it is given, not all of them (`build_parser`): a
command's start imports what that command runs on, and the names in `COMMAND_MODULES` are the
commands' own."""

import importlib
import subprocess
import sys

from wiithrow.app.cli.main import COMMAND_MODULES, build_parser


def test_the_names_are_the_commands_own_in_help_order():
    for name, module in COMMAND_MODULES.items():
        assert name == importlib.import_module(module).NAME
    help_text = build_parser().format_help()
    positions = [help_text.index(f"\n    {name}") for name in COMMAND_MODULES]
    assert positions == sorted(positions)


def test_a_command_starts_without_the_other_commands_modules():
    code = (
        "import sys; from wiithrow.app.cli.main import COMMAND_MODULES, main; "
        "assert main(['listen', '--help']) == 0; "
        "print(sorted(n for n, m in COMMAND_MODULES.items() if m in sys.modules)); "
        "print(sorted(m for m in ('scipy', 'numba', 'pinocchio', 'viser', 'mujoco') if m in sys.modules))"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True, timeout=60).stdout
    commands, heavy = out.splitlines()[-2:]
    assert commands == "['listen']"
    assert heavy == "[]"  # a Zenoh subscriber's command needs none of them


def test_an_unknown_command_is_told_every_command(capsys):
    from wiithrow.app.cli.main import main

    assert main(["bogus"]) == 2
    err = capsys.readouterr().err
    assert "invalid choice: 'bogus'" in err and all(f"'{name}'" in err for name in COMMAND_MODULES)
