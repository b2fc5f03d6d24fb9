"""What the command line says of a word it does not know: an unknown flag or command, in one line
with the closest one it knows (`difflib.get_close_matches`).

* `unknown_flag_message(parser, args, extras)`: the line for what argparse could not place
  (`parse_known_args`' extras): the first unknown flag, "wiithrow throw: unknown flag --calibraton
  (did you mean --calibration?)", matched (without the dashes) against the option strings of the
  (sub)parser that read the command (`library use` its own); a stray value, "unrecognized
  arguments: ...".
* `unknown_command_message(word, commands)`: "wiithrow: unknown command 'thro' (did you mean
  throw?)"; None when nothing is close (argparse's own line then lists every command).
"""

from __future__ import annotations

import argparse
import difflib
from collections.abc import Iterable, Sequence

#: How alike (difflib's ratio, 0-1) a known word must be to be suggested: difflib's default.
CUTOFF = 0.6


def closest(word: str, known: Iterable[str]) -> str | None:
    """The known word most like `word`, when one is alike enough (`CUTOFF`)."""
    found = difflib.get_close_matches(word, list(known), n=1, cutoff=CUTOFF)
    return found[0] if found else None


def chosen_parser(parser: argparse.ArgumentParser, args: argparse.Namespace) -> argparse.ArgumentParser:
    """The innermost (sub)parser `args` went through: `wiithrow throw`'s, `wiithrow library use`'s."""
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            name = getattr(args, action.dest, None)
            if isinstance(name, str) and name in action.choices:
                return chosen_parser(action.choices[name], args)
    return parser


def unknown_flag_message(parser: argparse.ArgumentParser, args: argparse.Namespace, extras: Sequence[str]) -> str:
    """The one line for `extras`, what `parser` could not place (module docstring)."""
    inner = chosen_parser(parser, args)
    flags = [word for word in extras if word.startswith("-") and len(word) > 1]
    if not flags:
        return f"{inner.prog}: unrecognized arguments: {' '.join(extras)} (see `{inner.prog} --help`)"
    flag = flags[0].partition("=")[0]
    # compared without their dashes: every long flag shares "--", which made --bogus "like" --out
    known = {option.lstrip("-"): option for action in inner._actions for option in action.option_strings}
    name = closest(flag.lstrip("-"), known)
    match = None if name is None else known[name]
    hint = f"did you mean {match}?" if match is not None else f"see `{inner.prog} --help`"
    return f"{inner.prog}: unknown flag {flag} ({hint})"


def unknown_command_message(word: str, commands: Iterable[str]) -> str | None:
    """The one line for a command that does not exist, when one is close (module docstring)."""
    match = closest(word, commands)
    return None if match is None else f"wiithrow: unknown command {word!r} (did you mean {match}?)"
