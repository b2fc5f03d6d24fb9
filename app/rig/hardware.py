"""Real remotes for the running system: one driver per Wiimote found by hidapi, in hidapi's order
(cam0 = the first remote = player LED 1, the left one as seen from behind the rig)."""

from __future__ import annotations

from wiithrow.app.errors import AppError
from wiithrow.clock import Clock
from wiithrow.vision.wiimote import transport
from wiithrow.vision.wiimote.device import WiimoteDriver
from wiithrow.vision.wiimote.driver_settings import DriverSettings


def hardware_drivers(
    count: int, clock: Clock, *, sensitivity: str = "level3", ir_format: str = "extended"
) -> list[WiimoteDriver]:
    """Drivers for the first `count` connected remotes. AppError, saying what to do, when fewer
    are connected or one of them cannot be opened (no permission on its hidraw node)."""
    found = transport.find_wiimotes()
    if len(found) < count:
        raise AppError(
            f"{len(found)} Wiimote(s) found, the rig needs {count}: pair them (see `wiithrow devices` and the "
            "docs/bring-up/hardware.md); `wiithrow demo` runs the whole system in simulation"
        )
    if any(info.accessible is False for info in found[:count]):
        raise AppError(f"a Wiimote cannot be opened (permission denied): {transport.UDEV_HINT}")
    return [
        WiimoteDriver(
            transport.wiimote_factory(serial=info.serial or None, index=i),
            clock,
            DriverSettings(sensitivity=sensitivity, ir_format=ir_format, player_led=i + 1),
            name=f"cam{i}",
        )
        for i, info in enumerate(found[:count])
    ]
