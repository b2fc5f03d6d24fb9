"""`wiithrow serve`: the dashboard over real hardware (remotes found by hidapi, arm driver from
settings).

The remotes side is complete (`vision.wiimote`); an arm driver is whatever implements
`robot.interface.Arm` for the real robot, and this installation ships none. `serve` therefore
checks what it can (the remotes are there and can be opened) and says exactly what is missing,
instead of pretending: `wiithrow demo` runs the whole system in simulation, `wiithrow track` uses
real remotes alone.
"""

from __future__ import annotations

import argparse

from app.errors import AppError

NAME = "serve"
HELP = "the dashboard on real hardware (remotes by hidapi, arm driver from settings)"

def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--host", default="127.0.0.1", help="address to bind (default: 127.0.0.1, this machine only)")
    parser.add_argument("--port", type=int, default=8080, help="port (default: 8080)")
    parser.add_argument("--settings", help="settings JSON (the arm and rig)")


def run(args: argparse.Namespace) -> int:
    from app.settings import Settings
    from vision.wiimote.transport import find_wiimotes

    settings = Settings.load(args.settings) if args.settings else Settings()
    remotes = find_wiimotes()
    if len(remotes) < settings.rig.count:
        raise AppError(
            f"{len(remotes)} Wiimote(s) found, the rig needs {settings.rig.count}: pair them (see `wiithrow devices` "
            "and the README, 'Real hardware'); `wiithrow demo` runs the whole system in simulation"
        )
    denied = [r for r in remotes if r.accessible is False]
    if denied:
        raise AppError("a Wiimote cannot be opened (permission denied): install the udev rule from the README, 'Real hardware'")
    raise AppError(
        f"no driver for a real {settings.arm!r} arm is installed (a driver implements robot.interface.Arm); "
        "the remotes are ready: `wiithrow track --calibration FILE` tracks markers with them, "
        "`wiithrow demo` runs the whole system in simulation"
    )
