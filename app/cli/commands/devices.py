"""`wiithrow devices`: list the connected Wiimotes and say whether we may open them.

For each remote hidapi finds (vendor 0x057E, products 0x0306 RVL-CNT-01 and 0x0330
RVL-CNT-01-TR): its path, model, product string and serial (the Bluetooth address), and whether
the hidraw node can be opened. Says clearly when there are none (with how to pair one) and when
access is denied (with the udev rule). Exit status 0, or 2 when a remote is found that we may
not open (the user has to fix permissions first).
"""

from __future__ import annotations

import argparse
import sys

from wiithrow.app.cli.json_output import emit
from wiithrow.vision.wiimote.transport import (
    KERNEL_DRIVER_HINT,
    UDEV_HINT,
    UDEV_RULE,
    DeviceInfo,
    find_wiimotes,
    platform_notes,
)

NAME = "devices"
HELP = "list connected Wiimotes (path, model, serial) and whether they can be opened"

PAIRING_HINT = (
    "pair a remote first: press 1+2 (or the red sync button under the battery cover) and connect it, "
    "e.g. with bluetoothctl (scan on, pair/trust/connect <address>); see docs/bring-up/hardware.md"
)


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--json", action="store_true", help="print the listing as JSON")


def _access_text(d: DeviceInfo) -> str:
    if d.accessible is None:
        return "access unknown"
    return "accessible" if d.accessible else "ACCESS DENIED"


def run(args: argparse.Namespace) -> int:
    devices = find_wiimotes()
    notes = platform_notes()
    denied = [d for d in devices if d.accessible is False]
    if getattr(args, "json", False):
        doc = {
            "schema": 1,
            "devices": [d.to_json() for d in devices],
            "access_denied": bool(denied),
            "hints": ([UDEV_HINT] if denied else []) + ([] if devices else [PAIRING_HINT]) + notes,
            "udev_rule": UDEV_RULE,
        }
        emit(doc)
        return 2 if denied else 0

    if not devices:
        print("No Wiimote found.")
        print(f"  To use one, {PAIRING_HINT}.")
    else:
        print(f"{len(devices)} Wiimote{'s' if len(devices) != 1 else ''} found:")
        for i, d in enumerate(devices):
            serial = d.serial or "no serial"
            product = d.product or "no product string"
            print(f"  [{i}] {d.path_str}  {d.model} ({product}, {serial})  {_access_text(d)}")
    if denied:
        print(
            f"Access to {len(denied)} of them is denied: {UDEV_HINT}. Also, {KERNEL_DRIVER_HINT}.",
            file=sys.stderr,
        )
    for note in notes:
        print(f"Note: {note}", file=sys.stderr)
    return 2 if denied else 0
