"""The Wiimote as a device: HID protocol, transports, the driver and a simulated remote.

- `protocol`: the protocol's vocabulary (report ids and lengths, flags, buttons, IR formats,
  registers, sensitivities) and `ProtocolError`;
- `output_reports`, `input_reports`, `ir_dots`: the byte layouts, pure encoders and `parse` (no I/O);
- `transport`: the `Transport` interface, `HidTransport` over hidapi, `find_wiimotes`;
- `simulator`: `SimulatedWiimote`, a `Transport` that behaves like a real remote byte for byte;
- `device`: `WiimoteDriver`, which starts the IR camera and turns reports into `IRFrame`s.

Hardware notes (pairing, udev, the kernel driver, the -TR model): the README, "Real hardware".
"""

from wiithrow.vision.wiimote.device import WiimoteDriver
from wiithrow.vision.wiimote.driver_settings import DriverSettings, DriverState, DriverStats, WiimoteError
from wiithrow.vision.wiimote.frames import IRFrame
from wiithrow.vision.wiimote.input_reports import parse
from wiithrow.vision.wiimote.protocol import Button, IRFormat, ProtocolError
from wiithrow.vision.wiimote.simulator import SimFaults, SimulatedWiimote
from wiithrow.vision.wiimote.transport import (
    DeviceAccessError,
    DeviceInfo,
    HidTransport,
    Transport,
    find_wiimotes,
    wiimote_factory,
)

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
