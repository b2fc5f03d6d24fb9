"""The Wiimote as a device: HID protocol, transports, the driver and a simulated remote.

- `protocol`: the protocol's vocabulary (report ids and lengths, flags, buttons, IR formats,
  registers, sensitivities) and `ProtocolError`;
- `output_reports`, `input_reports`, `ir_dots`: the byte layouts, pure encoders and `parse` (no I/O);
- `transport`: the `Transport` interface, `HidTransport` over hidapi, `find_wiimotes`;
- `device`: `WiimoteDriver`, which starts the IR camera and turns reports into `IRFrame`s, with
  `driver_settings` (`DriverSettings`, `DriverState`, `DriverStats`), `frames` (`IRFrame`, the
  frame assembly and its time stamps) and `link` (timed reads and writes on the transport);
- `simulator`: `SimulatedWiimote`, a `Transport` that behaves like a real remote byte for byte,
  with `sim_memory` (registers, EEPROM, the camera's start protocol), `sim_reports` (what its
  camera sees and the report bytes), `sim_buffer` (the HID buffer) and `sim_faults` (`SimFaults`,
  `SimStats`, `SentReport`).

Hardware notes (pairing, udev, the kernel driver, the -TR model): the docs/bring-up/hardware.md.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from wiithrow.lazy_exports import lazy_exports

if TYPE_CHECKING:
    from wiithrow.vision.wiimote.device import WiimoteDriver
    from wiithrow.vision.wiimote.driver_settings import DriverSettings, DriverState, DriverStats, WiimoteError
    from wiithrow.vision.wiimote.frames import IRFrame
    from wiithrow.vision.wiimote.input_reports import parse
    from wiithrow.vision.wiimote.protocol import Button, IRFormat, ProtocolError
    from wiithrow.vision.wiimote.sim_faults import SimFaults
    from wiithrow.vision.wiimote.simulator import SimulatedWiimote
    from wiithrow.vision.wiimote.transport import (
        DeviceAccessError,
        DeviceInfo,
        HidTransport,
        Transport,
        find_wiimotes,
        wiimote_factory,
    )

#: Each public name and the module that defines it (imported when first read: `wiithrow.lazy_exports`;
#: the simulator alone would bring in scipy through the camera model).
_HOMES = {
    "WiimoteDriver": "device",
    "DriverSettings": "driver_settings",
    "DriverState": "driver_settings",
    "DriverStats": "driver_settings",
    "WiimoteError": "driver_settings",
    "IRFrame": "frames",
    "parse": "input_reports",
    "Button": "protocol",
    "IRFormat": "protocol",
    "ProtocolError": "protocol",
    "SimFaults": "sim_faults",
    "SimulatedWiimote": "simulator",
    "DeviceAccessError": "transport",
    "DeviceInfo": "transport",
    "HidTransport": "transport",
    "Transport": "transport",
    "find_wiimotes": "transport",
    "wiimote_factory": "transport",
}

__all__ = [
    "Button",
    "DeviceAccessError",
    "DeviceInfo",
    "DriverSettings",
    "DriverState",
    "DriverStats",
    "HidTransport",
    "IRFormat",
    "IRFrame",
    "ProtocolError",
    "SimFaults",
    "SimulatedWiimote",
    "Transport",
    "WiimoteDriver",
    "WiimoteError",
    "find_wiimotes",
    "parse",
    "wiimote_factory",
]

__getattr__, __dir__ = lazy_exports(__name__, _HOMES)
