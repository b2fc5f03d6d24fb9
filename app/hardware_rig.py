"""Real remotes for the running system: one driver per Wiimote found by hidapi, in hidapi's order
(cam0 = the first remote = player LED 1, the left one as seen from behind the rig)."""

from __future__ import annotations

from app.errors import AppError
from vision.clock import Clock
from vision.wiimote.device import WiimoteDriver
from vision.wiimote.transport import find_wiimotes, wiimote_factory


def hardware_drivers(count: int, clock: Clock, *, sensitivity: str = "level3", ir_format: str = "extended") -> list[WiimoteDriver]:
    """Drivers for the first `count` connected remotes; AppError when fewer are connected."""
    found = find_wiimotes()
    if len(found) < count:
        raise AppError(
            f"{len(found)} Wiimote(s) connected, the rig needs {count}: pair them first "
            "(see `wiithrow devices` and the README's 'Real hardware' section)"
        )
    return [
        WiimoteDriver(wiimote_factory(serial=info.serial or None, index=i), clock, sensitivity=sensitivity,
                      ir_format=ir_format, player_led=i + 1, name=f"cam{i}")
        for i, info in enumerate(found[:count])
    ]
