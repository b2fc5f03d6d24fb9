"""The real-hardware world behind `wiithrow serve`: remotes through their drivers (here simulated
remotes speaking HID bytes on the system clock, in place of hidapi's), an arm from the settings'
driver or parked, sources the operator places, and the dashboard that refuses what cannot run."""

from __future__ import annotations

import threading
import time
import types

import numpy as np
import pytest

from wiithrow.app.cli.main import main
from wiithrow.app.errors import AppError
from wiithrow.app.rig.simulated import simulated_drivers
from wiithrow.app.rig.source import newest_t
from wiithrow.app.rig.waiting import pump
from wiithrow.app.session import Operation, Session
from wiithrow.app.settings import Settings
from wiithrow.app.worlds import nominal_cameras
from wiithrow.app.worlds.hardware import HardwareWorld, load_arm_driver
from wiithrow.clock import SystemClock
from wiithrow.robot import ParkedArm, RobotError, SimulatedArm, load_arm
from wiithrow.vision import StereoCalibration
from wiithrow.vision.dlt import CalibratedCamera

#: A fixed IR source in link1, 1.3 m in front of the rig, in both cameras' view.
SOURCE_LINK1 = np.array([1.3, 0.05, 0.2])


def remote_drivers(seed: int = 0):
    """Drivers of two simulated remotes on the system clock that see SOURCE_LINK1."""
    cameras = nominal_cameras(Settings().rig)
    drivers, _ = simulated_drivers(
        cameras, lambda t: SOURCE_LINK1[None], SystemClock(), np.random.default_rng(seed), realtime=True
    )
    return drivers


def true_calibration() -> StereoCalibration:
    """The nominal cameras' projection matrices as a calibration (what the remotes are)."""
    cameras = tuple(
        CalibratedCamera(c.P, "true", np.zeros((0, 3)), np.zeros((0, 2)), np.zeros(0), np.zeros(0, bool), name=c.name)
        for c in nominal_cameras(Settings().rig)
    )
    return StereoCalibration(cameras, "link1")


def make_arm(model, clock):  # an arm driver factory, as a settings file names it
    return SimulatedArm(model, clock)


def not_an_arm(model, clock):
    return object()


def test_without_a_driver_the_arm_is_parked_and_refuses_to_move():
    world = HardwareWorld(drivers=remote_drivers())
    assert isinstance(world.arm, ParkedArm) and not world.arm_connected and not world.simulated
    assert np.allclose(world.arm.state().q, world.arm_model.home)
    with pytest.raises(RobotError, match="no arm driver"):
        world.arm.command_position(world.arm_model.home)
    world.arm.stop()  # Stop always works
    assert not world.arm.is_moving() and world.arm.wait_until_idle(0.1)


def test_the_remotes_track_a_source_through_their_drivers():
    world = HardwareWorld(drivers=remote_drivers(), calibration=true_calibration())
    seen: list = []
    try:
        world.connect()
        since = newest_t(world.rig)
        deadline = time.monotonic() + 30.0  # 30 frames take 0.3 s of 100 Hz remotes: a loaded machine has 100 x that
        while len(seen) < 30 and time.monotonic() < deadline:
            pump(world.clock, world.rig, 0.1, step_s=0.005)
            frames = world.rig.tracked_since(since)
            seen = [f for f in frames if len(f) and np.asarray(f.visible).any()]
    finally:
        world.close()
    assert len(seen) >= 30, f"{len(seen)} tracked frames within 30 s of 100 Hz remotes"
    position = np.asarray(seen[-1].position)[np.asarray(seen[-1].visible)][0]
    assert np.linalg.norm(position - SOURCE_LINK1) < 0.01
    assert np.isnan(world.source_positions_base()).all(), "the truth is unknown on hardware"


def test_sources_are_placed_by_the_operator_not_from_here():
    world = HardwareWorld(drivers=remote_drivers())
    with pytest.raises(AppError, match="IR source you place"):
        world.light("target", True, [1.3, 0.0, 0.0])
    world.light("marker", True)  # the hand LED: the driver's, or the operator's to light
    assert world.lit()["marker"]


def test_the_arm_driver_comes_from_the_settings():
    settings = Settings().replace(arm_driver="tests.app.test_hardware_world:make_arm")
    world = HardwareWorld(settings, drivers=remote_drivers())
    assert isinstance(world.arm, SimulatedArm) and world.arm_connected
    model, clock = load_arm("pa10"), SystemClock()
    for spec, message in (
        ("no_colon", "module:factory"),
        ("tests.nowhere:make", "cannot import"),
        ("tests.app.test_hardware_world:missing", "no callable 'missing'"),
        ("tests.app.test_hardware_world:not_an_arm", "does not implement wiithrow.robot.interface.Arm"),
    ):
        with pytest.raises(AppError, match=message):
            load_arm_driver(spec, model, clock)
    with pytest.raises(AppError, match="must be a string"):
        Settings.from_dict({"arm_driver": 3})


def test_a_throw_without_a_gripper_driver_is_refused_before_anything_moves():
    settings = Settings().replace(arm_driver="tests.app.test_hardware_world:make_arm")
    session = Session(HardwareWorld(settings, drivers=remote_drivers()))
    assert "gripper driver" in session.refusal(Operation.THROW)
    with pytest.raises(AppError, match="gripper driver"):
        session.throw(1)
    assert session.history == () and not session.busy
    assert session.refusal(Operation.MEASURE_LANDING).startswith("throw first")
    with pytest.raises(AppError, match="throw first"):
        session.measure_landing()
    session.close()


def test_serve_runs_the_dashboard_over_the_remotes_with_the_arm_buttons_disabled(tmp_path, capsys, monkeypatch):
    from wiithrow.web import server

    calibration = tmp_path / "cal.json"
    true_calibration().save(calibration)
    dashboards = []
    original = server.Dashboard.start

    def start(self):  # keep a handle on the dashboard that serve builds
        dashboards.append(self)
        original(self)

    monkeypatch.setattr(server.Dashboard, "start", start)
    seen = {}

    def inspect():
        end = time.monotonic() + 10.0
        while time.monotonic() < end:
            if dashboards and dashboards[0].meter.count > 5:
                d = dashboards[0]
                from wiithrow.web.live import read_live_state

                live = read_live_state(d.session)
                seen["markers"] = live.markers.copy()
                seen["dots"] = live.dots.copy()
                seen["buttons"] = dict(d.states)
                seen["status"] = d.panels.status.content
                if len(live.markers):
                    return
            time.sleep(0.1)

    inspector = threading.Thread(target=inspect)
    inspector.start()
    from wiithrow.app.cli.commands import serve

    args = types.SimpleNamespace(
        host="127.0.0.1",
        port=0,
        settings=None,
        calibration=str(calibration),
        poses=30,
        library=None,
        no_learn=False,
        duration=4.0,
        plain_scene=False,
    )
    assert serve.run(args, drivers=remote_drivers()) == 0
    inspector.join()
    out = capsys.readouterr()
    assert "http://127.0.0.1:" in out.out and "no arm driver" in out.err
    assert len(seen.get("markers", ())) == 1, seen
    home_link1 = load_arm("pa10").frame_placement(load_arm("pa10").home, "link1")
    expected = home_link1[:3, :3] @ SOURCE_LINK1 + home_link1[:3, 3]
    assert np.linalg.norm(seen["markers"][0] - expected) < 0.01, "the marker is drawn in base, via the parked link1"
    assert np.isfinite(seen["dots"][:, 0]).all(), "each remote's view shows its dot"
    arm = [op for op in seen["buttons"] if op is not Operation.CALIBRATE_WAND]  # a wand calibration needs no arm
    assert arm and all("no arm driver" in seen["buttons"][op] for op in arm), seen["buttons"]
    assert "arm parked" in seen["status"]


def test_serve_without_remotes_says_what_to_do(monkeypatch, capsys):
    import wiithrow.vision.wiimote.transport as transport

    monkeypatch.setattr(transport, "find_wiimotes", lambda hid_module=None: [])
    assert main(["serve", "--port", "0"]) == 2
    assert "0 Wiimote(s) found, the rig needs 2" in capsys.readouterr().err


def test_a_remote_without_permission_is_named_before_anything_starts(monkeypatch):
    import wiithrow.vision.wiimote.transport as transport
    from wiithrow.app.rig.hardware import hardware_drivers

    denied = transport.DeviceInfo(
        path=b"/dev/hidraw3",
        vendor_id=0x057E,
        product_id=0x0306,
        serial="",
        product="",
        manufacturer="",
        interface=-1,
        accessible=False,
    )
    monkeypatch.setattr(transport, "find_wiimotes", lambda hid_module=None: [denied, denied])
    with pytest.raises(AppError, match="permission denied.*udev"):
        hardware_drivers(2, SystemClock())


def test_each_driver_the_settings_name_is_reported_with_its_file_before_it_runs(tmp_path, monkeypatch):
    """A settings file runs the code it names (README, "Settings files run code"): the world says
    which module file each driver came from, before the factory runs (the report comes first
    even when the factory fails)."""
    import sys

    (tmp_path / "lab_arm.py").write_text("def make(model, clock):\n    raise RuntimeError('the factory ran')\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    told = []
    settings = Settings().replace(arm_driver="lab_arm:make")
    with pytest.raises(RuntimeError, match="the factory ran"):
        HardwareWorld(settings, drivers=remote_drivers(), on_load=told.append)
    assert [str(d) for d in told] == [f"arm_driver lab_arm:make from {tmp_path / 'lab_arm.py'}"]
    sys.modules.pop("lab_arm", None)

    world = HardwareWorld(
        Settings().replace(arm_driver="tests.app.test_hardware_world:make_arm"), drivers=remote_drivers()
    )
    assert [(d.key, d.spec, d.file) for d in world.loaded] == [
        ("arm_driver", "tests.app.test_hardware_world:make_arm", __file__)
    ]


def test_serve_prints_the_drivers_it_loaded(capsys):
    """One line per driver: the spec and the module file it resolved to (the MuJoCo devices)."""
    from pathlib import Path

    import wiithrow.app.worlds.mujoco.drivers as drivers

    settings = Path(__file__).resolve().parents[2] / "examples" / "mujoco_settings.json"
    assert main(["serve", "--settings", str(settings), "--duration", "0.2", "--port", "0"]) == 0
    loaded = [line for line in capsys.readouterr().err.splitlines() if " loaded " in line]
    assert loaded == [
        f"wiithrow serve: loaded {key} wiithrow.app.worlds.mujoco.drivers:{name} from {drivers.__file__}"
        for key, name in (("arm_driver", "arm"), ("gripper_driver", "gripper"), ("remotes_driver", "remotes"))
    ]
