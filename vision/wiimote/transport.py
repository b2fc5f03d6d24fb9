"""Moving report bytes to and from a remote: the transport interface and its hidapi implementation.

`Transport` is all the driver needs of a device: `open()`, `write(report) -> int`,
`read(max_size, timeout_ms) -> bytes` (b"" on timeout) and `close()`. A vanished device shows
as `OSError` from `read`/`write`/`open`, as with hidapi. `HidTransport` implements it over
hidapi (the `hid` module of the `hidapi` package); `wiithrow.vision.wiimote.simulator.SimulatedWiimote`
implements it in memory.

hidapi notes that shape this code:
- byte 0 of every read and write is the report id (no Bluetooth 0xA1/0xA2 prefix);
- writes go out exactly as long as the report (Windows pads to 22 bytes if asked to, which some
  Bluetooth stacks reject, so we never pad);
- `hid.device.read(n, 0)` blocks forever unless the device is non-blocking, so the handle is put
  in non-blocking mode and a positive timeout goes to `hid_read_timeout`;
- `write` returns -1 on failure instead of raising; `read` raises `OSError('read error')`.
On Linux, /dev/hidraw* needs a udev rule for non-root access, and the kernel's hid-wiimote
driver, when bound to the remote, consumes and re-configures it behind our back.
"""

from __future__ import annotations

import os
import sys
from collections.abc import Callable
from dataclasses import asdict, dataclass
from pathlib import Path
from types import ModuleType
from typing import Any, Protocol, runtime_checkable

from wiithrow.vision.errors import VisionError
from wiithrow.vision.wiimote.protocol import MAX_REPORT_LENGTH, MODEL_NAMES, VENDOR_ID

UDEV_RULE = 'KERNEL=="hidraw*", ATTRS{idVendor}=="057e", MODE="0660", GROUP="plugdev"'
UDEV_HINT = (
    "give your user access to the remotes' hidraw nodes with a udev rule, e.g. in "
    f"/etc/udev/rules.d/70-wiimote.rules: {UDEV_RULE} ; then `sudo udevadm control --reload-rules "
    "&& sudo udevadm trigger`, add yourself to the plugdev group and reconnect the remote"
)
KERNEL_DRIVER_HINT = (
    "if the kernel's hid-wiimote driver is bound to the remote it fights a raw reader: unbind it "
    "(echo the device name to /sys/bus/hid/drivers/wiimote/unbind) or blacklist it "
    "(`blacklist hid_wiimote` in /etc/modprobe.d/)"
)


class DeviceAccessError(VisionError):
    """A remote exists but cannot be opened: permission denied on its hidraw node, or hidapi missing."""


@runtime_checkable
class Transport(Protocol):
    """What the driver needs of a device. Errors of a vanished device are `OSError`."""

    def open(self) -> None:
        """Open the device (again, after `close`); `OSError` when it is not there."""

    def write(self, data: bytes) -> int:
        """Send one output report (byte 0 = id), exactly as long as given; bytes written."""

    def read(self, max_size: int, timeout_ms: int) -> bytes:
        """One input report (byte 0 = id), waiting up to `timeout_ms`; b"" on timeout."""

    def close(self) -> None:
        """Release the device; harmless when already closed."""


@dataclass(frozen=True)
class DeviceInfo:
    """One remote as hidapi enumerates it."""

    path: bytes
    vendor_id: int
    product_id: int
    serial: str = ""
    product: str = ""
    manufacturer: str = ""
    interface: int = -1
    accessible: bool | None = None  # read/write permission on the node; None when unknown

    @property
    def model(self) -> str:
        """RVL-CNT-01 or RVL-CNT-01-TR (Wii Remote Plus)."""
        return MODEL_NAMES.get(self.product_id, f"unknown product {self.product_id:#06x}")

    @property
    def path_str(self) -> str:
        return self.path.decode("utf-8", "replace")

    def to_json(self) -> dict[str, Any]:
        d = asdict(self)
        d["path"] = self.path_str
        d["model"] = self.model
        return d


def _load_hid(hid_module: ModuleType | None) -> ModuleType:
    if hid_module is not None:
        return hid_module
    try:
        import hid  # the `hidapi` package (no type information: the import is Any to mypy)
    except ImportError as exc:  # pragma: no cover - hidapi is a dependency
        raise DeviceAccessError(
            f"cannot use Wiimotes: the hidapi package is not importable ({exc}); pip install hidapi"
        ) from exc
    module: ModuleType = hid
    return module


def node_accessible(path: bytes | str) -> bool | None:
    """Whether we may read and write the device node at `path` (None when `path` is not a file,
    as with hidapi's libusb or macOS backends)."""
    p = path.decode("utf-8", "replace") if isinstance(path, bytes) else str(path)
    if not p.startswith("/dev/") or not os.path.exists(p):
        return None
    return os.access(p, os.R_OK | os.W_OK)


def find_wiimotes(hid_module: ModuleType | None = None) -> list[DeviceInfo]:
    """The connected Wiimotes (vendor 0x057E, product 0x0306 or 0x0330), in hidapi's order.

    Enumerates with `hid.enumerate(0x057E, 0)` and filters the products, so both models come out
    of one call. Enumeration needs no permission; `DeviceInfo.accessible` says whether opening
    will be allowed.
    """
    hid = _load_hid(hid_module)
    found: list[DeviceInfo] = []
    seen: set[bytes] = set()
    for d in hid.enumerate(VENDOR_ID, 0):
        if d.get("vendor_id") != VENDOR_ID or d.get("product_id") not in MODEL_NAMES:
            continue
        path = d.get("path") or b""
        if isinstance(path, str):
            path = path.encode()
        if path in seen:
            continue
        seen.add(path)
        found.append(
            DeviceInfo(
                path=path,
                vendor_id=int(d["vendor_id"]),
                product_id=int(d["product_id"]),
                serial=d.get("serial_number") or "",
                product=d.get("product_string") or "",
                manufacturer=d.get("manufacturer_string") or "",
                interface=int(d.get("interface_number") if d.get("interface_number") is not None else -1),
                accessible=node_accessible(path),
            )
        )
    return found


def wiimote_factory(
    serial: str | None = None, index: int = 0, *, hid_module: ModuleType | None = None
) -> Callable[[], HidTransport]:
    """A transport factory for `WiimoteDriver` that finds the remote again at every (re)connect.

    A remote's hidraw path changes when it reconnects (/dev/hidraw3 may come back as
    /dev/hidraw5), so the driver should reopen by identity, not by path: by `serial` (its
    Bluetooth address, as `find_wiimotes` reports it) or else by position `index`. Raises
    `OSError` (the driver then backs off and retries) while the remote is not there.
    """

    def make() -> HidTransport:
        devices = find_wiimotes(hid_module)
        if serial is not None:
            devices = [d for d in devices if d.serial.lower() == serial.lower()]
        if len(devices) <= index:
            which = f"with serial {serial}" if serial is not None else f"number {index}"
            raise OSError(f"Wiimote {which} not found ({len(devices)} connected)")
        return HidTransport(devices[index].path, hid_module=hid_module)

    return make


def kernel_driver_bindings(sysfs: str | os.PathLike[str] = "/sys/bus/hid/drivers/wiimote") -> list[str]:
    """HID devices the kernel's hid-wiimote driver is bound to (Linux; empty elsewhere)."""
    root = Path(sysfs)
    try:
        return sorted(p.name for p in root.iterdir() if ":057E:" in p.name.upper())
    except OSError:
        return []


class HidTransport:
    """A remote through hidapi, by device path (see `find_wiimotes`)."""

    def __init__(self, path: bytes | str, *, hid_module: ModuleType | None = None) -> None:
        self.path = path.encode() if isinstance(path, str) else bytes(path)
        self._hid_module = hid_module
        self._dev: Any = None

    @classmethod
    def first(cls, *, hid_module: ModuleType | None = None) -> HidTransport:
        """The first Wiimote hidapi finds; `DeviceAccessError` when there is none."""
        devices = find_wiimotes(hid_module)
        if not devices:
            raise DeviceAccessError("no Wiimote found: pair one first (press 1+2 or the red sync button)")
        return cls(devices[0].path, hid_module=hid_module)

    @property
    def is_open(self) -> bool:
        return self._dev is not None

    def open(self) -> None:
        if self._dev is not None:
            return
        hid = _load_hid(self._hid_module)
        dev = hid.device()
        try:
            dev.open_path(self.path)
        except OSError as exc:
            if node_accessible(self.path) is False:
                raise DeviceAccessError(
                    f"permission denied opening the Wiimote at {self.path.decode('utf-8', 'replace')}: "
                    f"{UDEV_HINT}. Also, {KERNEL_DRIVER_HINT}"
                ) from exc
            raise OSError(f"cannot open the Wiimote at {self.path.decode('utf-8', 'replace')}: {exc}") from exc
        try:
            dev.set_nonblocking(1)
        except (OSError, ValueError):  # pragma: no cover - only a closed handle refuses
            pass
        self._dev = dev

    def write(self, data: bytes) -> int:
        dev = self._require_open()
        data = bytes(data)
        if not data:
            raise OSError("refusing to write an empty report")
        try:
            n = dev.write(data)  # exactly len(data) bytes: never padded
        except ValueError as exc:  # 'not open'
            raise OSError(f"write to a closed Wiimote: {exc}") from exc
        if n is None or n < 0:
            raise OSError(f"write of report {data[0]:#04x} failed: {self._error_text()}")
        return int(n)

    def read(self, max_size: int = MAX_REPORT_LENGTH, timeout_ms: int = 0) -> bytes:
        dev = self._require_open()
        try:
            if timeout_ms > 0:
                out = dev.read(int(max_size), int(timeout_ms))
            else:
                out = dev.read(int(max_size))  # non-blocking handle: returns at once
        except ValueError as exc:  # 'not open'
            raise OSError(f"read from a closed Wiimote: {exc}") from exc
        return bytes(out) if out else b""

    def close(self) -> None:
        dev, self._dev = self._dev, None
        if dev is not None:
            try:
                dev.close()
            except Exception:  # closing a vanished device must never fail the caller
                pass

    def _require_open(self) -> Any:
        if self._dev is None:
            raise OSError("the Wiimote is not open")
        return self._dev

    def _error_text(self) -> str:
        try:
            return str(self._dev.error())
        except Exception:
            return "unknown error"

    def __repr__(self) -> str:
        return f"HidTransport({self.path!r}, open={self.is_open})"


def platform_notes() -> list[str]:
    """Hints worth printing next to a device listing on this platform."""
    notes = []
    if sys.platform.startswith("linux"):
        bound = kernel_driver_bindings()
        if bound:
            notes.append(f"the kernel hid-wiimote driver is bound to {', '.join(bound)}; {KERNEL_DRIVER_HINT}")
    return notes
