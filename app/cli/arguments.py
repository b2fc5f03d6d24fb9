"""The command line's parser and argument types: a bad flag is one clear line and exit status 2.

* `Parser`: argparse with three changes. Its errors are one line, `wiithrow CMD: MESSAGE (see
  wiithrow CMD --help)`, not the usage block; an unknown flag is `wiithrow CMD: unknown flag --X
  (did you mean --Y?)` (`did_you_mean`). And an argument that is a negative number in any
  spelling float() reads (`-1e-3`, `-.5`, `-inf`) is a value, not an option: argparse's own rule
  knows only `-1` and `-1.5`, so `--target -1e-1 0 0` failed with "expected 3 arguments".
* Types that refuse what a command cannot use, at parse time: `seed` (0 to 2^63 - 1: numpy's
  generators take no negative seed), `positive_float` and `non_negative_float` (finite: `nan`
  compares false with everything, so `--duration nan` ran nothing and exited 0), `finite_float`,
  `positive_int`.
* `given(args, name)` and `refuse_flags`: flags whose default is None (or False) are given when
  they are not; a command refuses, in one line, flags that do not apply to what it was asked to
  do (`calibrate --points good.csv --sim` ignored --sim).
* `output_file(args, name, default)`: where an output flag writes, checked before the work
  (`wiithrow.vision.outputs.check_output_file`). A file the user named is replaced; the default
  file (`calibration.json`, `library.json`), which the user did not name, is never replaced
  without `--force`.
"""

from __future__ import annotations

import argparse
import math
import re
import sys
from collections.abc import Callable, Iterable, Sequence
from pathlib import Path
from typing import NoReturn

from wiithrow.app.errors import AppError
from wiithrow.vision.outputs import check_output_file

#: A negative number as float() reads it (argparse's own pattern is '^-\d+$|^-\d*\.\d+$').
NEGATIVE_NUMBER = re.compile(r"^-(\d+\.?\d*|\.\d+)([eE][+-]?\d+)?$|^-(inf|infinity|nan)$", re.IGNORECASE)

MAX_SEED = 2**63 - 1


class Parser(argparse.ArgumentParser):
    """argparse.ArgumentParser with one-line errors and numbers read as numbers (module docstring)."""

    def __init__(self, *args, **kwargs) -> None:
        super().__init__(*args, **kwargs)
        self._negative_number_matcher = NEGATIVE_NUMBER

    def error(self, message: str) -> NoReturn:
        print(f"{self.prog}: {message} (see `{self.prog} --help`)", file=sys.stderr)
        raise SystemExit(2)

    def parse_args(  # type: ignore[override]
        self, args: Sequence[str] | None = None, namespace: argparse.Namespace | None = None
    ) -> argparse.Namespace:
        """argparse's, but what it cannot place is one line naming the command and the closest flag
        (`did_you_mean.unknown_flag_message`), not "wiithrow: unrecognized arguments"."""
        parsed, extras = self.parse_known_args(args, namespace)
        if extras:
            from wiithrow.app.cli.did_you_mean import unknown_flag_message

            print(unknown_flag_message(self, parsed, extras), file=sys.stderr)
            raise SystemExit(2)
        return parsed


def _number(text: str) -> float:
    try:
        return float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not a number: {text!r}") from None


def _float_type(accept: Callable[[float], bool], wording: str) -> Callable[[str], float]:
    """An argument type: a number `accept` takes ('must be WORDING, got ...' otherwise)."""

    def parse(text: str) -> float:
        value = _number(text)
        if not accept(value):
            raise argparse.ArgumentTypeError(f"must be {wording}, got {text!r}")
        return value

    return parse


def _int_type(low: int, high: int | None, what: str, wording: str) -> Callable[[str], int]:
    """An argument type: an integer from `low` to `high` (None: no bound)."""

    def parse(text: str) -> int:
        try:
            value = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{what}, got {text!r}") from None
        if value < low or (high is not None and value > high):
            raise argparse.ArgumentTypeError(f"{wording}, got {value}")
        return value

    return parse


#: A finite number (no nan, no inf).
finite_float = _float_type(math.isfinite, "a finite number")
#: A finite number > 0.
positive_float = _float_type(lambda v: math.isfinite(v) and v > 0, "a finite number above 0")
#: A finite number >= 0.
non_negative_float = _float_type(lambda v: math.isfinite(v) and v >= 0, "a finite number of at least 0")
#: An integer >= 1.
positive_int = _int_type(1, None, "not an integer", "must be at least 1")
#: A TCP port, 0 (any free port) to 65535.
port = _int_type(0, 65535, "not a port number", "a port is 0-65535")
#: The dashboard's calibration poses: its Poses field takes 7 (leave-one-out needs 7) to 100
#: (web/panels.py); a default outside that range was a ValueError traceback from viser.
dashboard_poses = _int_type(7, 100, "not an integer", "the dashboard calibrates with 7 to 100 poses")
#: The remotes in a rig: 2 to 4 (`Settings.with_cameras` places them).
camera_count = _int_type(2, 4, "not an integer", "a rig has 2 to 4 remotes")
#: A random seed: an integer from 0 to 2^63 - 1.
seed = _int_type(0, MAX_SEED, "a seed is an integer", "a seed is an integer from 0 to 2^63 - 1")


def given(args: argparse.Namespace, name: str) -> bool:
    """Whether flag `name` (its dest) was given: its value is neither None nor False."""
    value = getattr(args, name, None)
    return value is not None and value is not False


def refuse_flags(args: argparse.Namespace, names: Iterable[str], why: str) -> None:
    """AppError naming the flags among `names` that were given: they do not apply (`why` says to what)."""
    bad = [f"--{name.replace('_', '-')}" for name in names if given(args, name)]
    if bad:
        raise AppError(f"{', '.join(bad)} {'does' if len(bad) == 1 else 'do'} not apply {why}")


def output_file(args: argparse.Namespace, name: str = "out", default: str | None = None) -> Path | None:
    """Where output flag `name` writes (None: neither given nor defaulted), checked before the
    work: the file the user named, or `default`, which an existing file blocks unless --force."""
    flag = f"--{name.replace('_', '-')}"
    value = getattr(args, name, None)
    if value is not None:
        return check_output_file(value, replace=True)
    if default is None:
        return None
    return check_output_file(
        default,
        replace=bool(getattr(args, "force", False)),
        hint=f"{flag} does not name it: pass {flag} FILE to write elsewhere, or --force to replace it",
    )


def add_world_argument(parser: argparse.ArgumentParser, default: str) -> None:
    """`--world mujoco|kinematic`: the simulated world a command runs in (`wiithrow.app.worlds.named`)."""
    from wiithrow.app.worlds.named import WORLDS

    parser.add_argument(
        "--world",
        choices=WORLDS,
        default=default,
        help="the simulated world: mujoco (physics the planner does not know) or kinematic (its own models) "
        f"(default: {default})",
    )


def add_learn_argument(parser: argparse.ArgumentParser) -> None:
    """`--no-learn`: measured throws do not join the throw library (`Session`'s learning; on by default)."""
    parser.add_argument(
        "--no-learn",
        action="store_true",
        help="keep the throw library as it is: measured throws do not join it (by default they do, each update "
        "a new version of the library folder, the file given by --library left as it is)",
    )
