"""A command's stderr without its opening: the world line every command that runs a world prints
first, and `track`'s line of how long it tracks; what remains is what the test judges."""

from __future__ import annotations

#: How the opening lines begin (app/cli/world_choice.py's world line, track.py's duration_line).
OPENING = ("world: ", "wiithrow track: tracking for ")


def after_opening(lines: list[str]) -> list[str]:
    """`lines` without the opening ones."""
    return [line for line in lines if not line.startswith(OPENING)]
