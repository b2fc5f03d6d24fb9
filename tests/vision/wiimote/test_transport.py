"""HidTransport and find_wiimotes against a fake `hid` module (no hardware here), and `wiithrow devices`."""

from __future__ import annotations

import json
import types

import numpy as np
import pytest

from wiithrow.app.cli.commands import devices as devices_cmd
from wiithrow.app.cli.main import main
from wiithrow.clock import SimClock
from wiithrow.vision.camera import WiimoteCamera
from wiithrow.vision.wiimote import transport as T
from wiithrow.vision.wiimote.device import WiimoteDriver
from wiithrow.vision.wiimote.simulator import SimulatedWiimote
from wiithrow.vision.wiimote.transport import (
    DeviceAccessError,
    DeviceInfo,
    HidTransport,
    Transport,
    find_wiimotes,
    wiimote_factory,
)


class FakeDevice:
    """hidapi's `hid.device`, as cython-hidapi 0.15 behaves: lists from read, -1 from a failed write."""

    def __init__(self, module):
        self.m = module
        self.opened = None
        self.nonblocking = None
        self.writes = []
        self.reads = []  # (max_length, timeout_ms or None)

    def open_path(self, path):
        if path not in self.m.present:
            raise OSError("open failed")
        self.opened = path

    def set_nonblocking(self, v):
        self.nonblocking = v
        return 0

    def write(self, buff):
        if self.opened is None:
            raise ValueError("not open")
        self.writes.append(bytes(buff))
        return -1 if self.m.fail_writes else len(buff)

    def read(self, max_length, timeout_ms=0):
        if self.opened is None:
            raise ValueError("not open")
        self.reads.append((max_length, timeout_ms if timeout_ms else None))
        if self.m.vanished:
            raise OSError("read error")
        return list(self.m.inbox.pop(0)[:max_length]) if self.m.inbox else []

    def error(self):
        return "Broken pipe"

    def close(self):
        self.opened = None


def fake_hid(entries=(), present=()):
    m = types.SimpleNamespace(present=set(present), inbox=[], vanished=False, fail_writes=False, devices=[])

    def device():
        d = FakeDevice(m)
        m.devices.append(d)
        return d

    m.device = device
    m.enumerate = lambda vid=0, pid=0: [e for e in entries if (vid == 0 or e["vendor_id"] == vid)]
    return m


def entry(path, vid=0x057E, pid=0x0306, serial="00:19:1d:aa:bb:cc", product="Nintendo RVL-CNT-01"):
    return {
        "path": path,
        "vendor_id": vid,
        "product_id": pid,
        "serial_number": serial,
        "release_number": 0x100,
        "manufacturer_string": "Nintendo",
        "product_string": product,
        "usage_page": 1,
        "usage": 5,
        "interface_number": -1,
    }


# ---------------------------------------------------------------- enumeration


def test_find_wiimotes_filters_vendor_and_products_and_names_models():
    hid = fake_hid(
        [
            entry(b"/dev/hidraw1"),
            entry(b"/dev/hidraw2", pid=0x0330, product="Nintendo RVL-CNT-01-TR"),
            entry(b"/dev/hidraw3", pid=0x0337),  # a Wii U GameCube adapter: not a remote
            entry(b"/dev/hidraw4", vid=0x046D),  # someone else's device
            entry(b"/dev/hidraw1"),  # listed twice by some backends
        ]
    )
    found = find_wiimotes(hid)
    assert [(d.path, d.model) for d in found] == [(b"/dev/hidraw1", "RVL-CNT-01"), (b"/dev/hidraw2", "RVL-CNT-01-TR")]
    assert found[0].serial == "00:19:1d:aa:bb:cc" and found[0].accessible is None  # no such node here
    assert find_wiimotes(fake_hid()) == []
    assert json.loads(json.dumps(found[1].to_json()))["model"] == "RVL-CNT-01-TR"


def test_node_accessible(tmp_path, monkeypatch):
    node = tmp_path / "hidraw9"
    node.write_bytes(b"")
    assert T.node_accessible(str(node)) is None  # not under /dev: unknown
    assert T.node_accessible("/dev/null") is True
    assert T.node_accessible(b"/dev/definitely-not-here") is None
    monkeypatch.setattr(T.os, "access", lambda p, mode: False)
    assert T.node_accessible("/dev/null") is False


# ---------------------------------------------------------------- HidTransport


def test_writes_are_exactly_the_report_length_and_reads_are_bytes():
    hid = fake_hid(present={b"/dev/hidraw1"})
    t = HidTransport("/dev/hidraw1", hid_module=hid)
    assert isinstance(t, Transport)
    t.open()
    dev = hid.devices[0]
    assert dev.nonblocking == 1
    for report in (
        bytes.fromhex("11 10"),
        bytes.fromhex("12 04 33"),
        bytes.fromhex("16 04 b0 00 30 01 08") + bytes(15),
    ):
        assert t.write(report) == len(report)
    assert [len(w) for w in dev.writes] == [2, 3, 22]  # never padded to 22
    hid.inbox.append(bytes.fromhex("22 00 00 16 00"))
    assert t.read(22, 50) == bytes.fromhex("22 00 00 16 00")
    assert t.read(22, 0) == b""
    assert dev.reads == [(22, 50), (22, None)]  # 0 ms: plain non-blocking read, never a blocking one
    t.close()
    t.close()
    with pytest.raises(OSError):
        t.read(22, 0)


def test_failed_write_and_vanished_device_are_oserrors():
    hid = fake_hid(present={b"/dev/hidraw1"})
    t = HidTransport(b"/dev/hidraw1", hid_module=hid)
    t.open()
    hid.fail_writes = True
    with pytest.raises(OSError, match="0x15 failed: Broken pipe"):
        t.write(bytes.fromhex("15 00"))
    hid.vanished = True
    with pytest.raises(OSError, match="read error"):
        t.read(22, 10)
    with pytest.raises(OSError):
        t.write(b"")


def test_open_missing_device_is_oserror_and_denied_is_device_access_error(monkeypatch):
    hid = fake_hid()
    with pytest.raises(OSError, match="cannot open the Wiimote at /dev/hidraw7"):
        HidTransport("/dev/hidraw7", hid_module=hid).open()
    monkeypatch.setattr(T, "node_accessible", lambda path: False)
    with pytest.raises(DeviceAccessError) as err:
        HidTransport("/dev/hidraw7", hid_module=hid).open()
    msg = str(err.value)
    assert 'KERNEL=="hidraw*", ATTRS{idVendor}=="057e", MODE="0660", GROUP="plugdev"' in msg
    assert "hid-wiimote" in msg and "permission denied" in msg


def test_first_wiimote_or_a_clear_error():
    with pytest.raises(DeviceAccessError, match="no Wiimote found"):
        HidTransport.first(hid_module=fake_hid())
    t = HidTransport.first(hid_module=fake_hid([entry(b"/dev/hidraw5")]))
    assert t.path == b"/dev/hidraw5"


def test_factory_finds_the_remote_by_serial_whatever_its_path():
    entries = [entry(b"/dev/hidraw1", serial="00:19:1d:aa:bb:cc"), entry(b"/dev/hidraw2", serial="00:1f:32:dd:ee:ff")]
    hid = fake_hid(entries)
    make = wiimote_factory("00:1F:32:DD:EE:FF", hid_module=hid)
    assert make().path == b"/dev/hidraw2"
    entries[1]["path"] = b"/dev/hidraw7"  # reconnected: a new node
    assert make().path == b"/dev/hidraw7"
    assert wiimote_factory(index=0, hid_module=hid)().path == b"/dev/hidraw1"
    del entries[1]
    with pytest.raises(OSError, match="serial 00:1F:32:DD:EE:FF not found"):
        make()
    with pytest.raises(OSError, match="number 3 not found"):
        wiimote_factory(index=3, hid_module=hid)()


def test_driver_runs_over_the_hid_transport_code_path():
    """The driver talks to the simulated remote through HidTransport's code path (fake hid module)."""
    clock = SimClock()
    cam = WiimoteCamera.at([0, 0, 0], [1, 0, 0])
    sim = SimulatedWiimote(cam, lambda t: np.array([[1.0, 0.0, 0.0]]), clock, np.random.default_rng(0), sigma_px=0)

    hid = fake_hid(present={b"/dev/hidraw1"})

    class SimDevice(FakeDevice):  # a fake hid.device whose other end is the simulator
        def open_path(self, path):
            super().open_path(path)
            sim.open()

        def write(self, buff):
            self.writes.append(bytes(buff))
            return sim.write(bytes(buff))

        def read(self, max_length, timeout_ms=0):
            return list(sim.read(max_length, timeout_ms))

    hid.device = lambda: SimDevice(hid)
    drv = WiimoteDriver(lambda: HidTransport(b"/dev/hidraw1", hid_module=hid), clock)
    drv.connect()
    frames = []
    for _ in range(20):
        clock.advance(0.01)
        frames += drv.poll()
    assert len(frames) == 21 and all(f.visible.sum() == 1 for f in frames)


# ---------------------------------------------------------------- wiithrow devices


def test_devices_command_without_hardware_says_none_found(capsys):
    assert main(["devices"]) == 0
    out = capsys.readouterr().out
    assert "No Wiimote found" in out and "1+2" in out
    assert main(["devices", "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert doc["devices"] == [] and doc["schema"] == 1 and not doc["access_denied"]


def test_devices_command_lists_and_warns_about_denied_access(capsys, monkeypatch):
    found = [
        DeviceInfo(b"/dev/hidraw1", 0x057E, 0x0306, "00:19:1d:aa:bb:cc", "Nintendo RVL-CNT-01", accessible=True),
        DeviceInfo(b"/dev/hidraw2", 0x057E, 0x0330, "00:1f:32:dd:ee:ff", "Nintendo RVL-CNT-01-TR", accessible=False),
    ]
    monkeypatch.setattr(devices_cmd, "find_wiimotes", lambda: found)
    monkeypatch.setattr(devices_cmd, "platform_notes", list)
    assert main(["devices"]) == 2
    cap = capsys.readouterr()
    assert "2 Wiimotes found" in cap.out
    assert "/dev/hidraw1  RVL-CNT-01 (Nintendo RVL-CNT-01, 00:19:1d:aa:bb:cc)  accessible" in cap.out
    assert "/dev/hidraw2  RVL-CNT-01-TR" in cap.out and "ACCESS DENIED" in cap.out
    assert 'ATTRS{idVendor}=="057e"' in cap.err and "hid-wiimote" in cap.err
    assert main(["devices", "--json"]) == 2
    doc = json.loads(capsys.readouterr().out)
    assert [d["model"] for d in doc["devices"]] == ["RVL-CNT-01", "RVL-CNT-01-TR"]
    assert doc["devices"][1]["accessible"] is False and doc["access_denied"]
