"""`wiithrow check-driver` measures, not believes: a driver that reports its commands as its state
(`tests.app.bad_drivers.echoing_arm`: the arm never moves) passed every check but the limits'
(slow motion 0.11 mrad RMS, Stop "at rest 0.000 s after it"); it now fails "state measured" (its
state equals the command bit for bit) and "seen moving" (the calibrated rig does not see the hand's
LED where the state puts it, nor moving as it says), while the project's own drivers pass both. A
hand without a scheduled open passes with a warning that the host times its release.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np
import pytest

from tests.app import bad_drivers
from tests.app.test_check_driver import EXAMPLE, mujoco_rig_calibration
from tests.helpers.host_timed_hand import HostTimedHand
from wiithrow.app.cli.main import main
from wiithrow.app.drivercheck import bounds, motions
from wiithrow.app.drivercheck.hand_probe import HOST_TIMED_WARNING, probe_hand
from wiithrow.app.drivercheck.procedure import CHECK_NAMES, run_checks
from wiithrow.app.drivercheck.report import DriverReport
from wiithrow.app.drivercheck.rig_probe import NO_RIG, probe_seen_moving, rig_watch, view_pose
from wiithrow.app.rig.waiting import wait_while_moving
from wiithrow.app.settings import Settings
from wiithrow.app.worlds import SimWorld
from wiithrow.app.worlds.mujoco.world import MujocoWorld
from wiithrow.clock import SimClock
from wiithrow.robot.gripper import SimulatedGripper


@pytest.fixture
def world():
    """The MuJoCo world of the example settings, its rig calibrated (the true cameras, in link1)."""
    w = MujocoWorld(Settings.load(EXAMPLE), seed=3)
    w.connect()
    w.set_calibration(w.true_calibration())
    yield w
    w.close()


def _checks(results) -> dict:
    assert tuple(r.name for r in results) == CHECK_NAMES
    return {r.name: r for r in results}


def test_an_echoing_driver_fails_state_measured_and_seen_moving(world):
    q_start = world.arm.state().q.copy()
    echo = bad_drivers.EchoingArm(world.arm, world.clock)
    checks = _checks(run_checks(echo, world.arm_model, world.clock, gripper=None, watch=rig_watch(world)))
    measured = checks["state measured"]
    assert measured.status == "fail" and "echoes its commands instead of measuring the arm" in measured.reason
    assert measured.figures["equal_to_command_fraction"] == 1.0 and measured.figures["moving_states"] > 1000
    assert any("no noise at rest" in w for w in measured.warnings)  # kept beside the failure
    seen = checks["seen moving"]
    assert seen.status == "fail" and "the arm is not where its state says" in seen.reason, seen.reason
    assert seen.figures["frames_in_view"] >= bounds.RIG_MIN_FRAMES and seen.figures["frames_seen"] == 0
    throw = checks["scaled throw"]
    assert throw.status == "not run" and "state measured" in throw.reason and "seen moving" in throw.reason
    # what the following checks believed: the arm followed the command to a tenth of a milliradian
    assert checks["slow motion"].status == "pass" and checks["slow motion"].figures["rms_rad"] < 0.001
    assert np.max(np.abs(world.arm.state().q - q_start)) < 0.002  # while the arm never moved


def test_an_echo_whose_standing_led_the_rig_sees_fails_on_the_travel(world):
    """The arm stands where the rig sees its LED; the echo's state moves (the check's own motion):
    the rig sees the LED within the gate of the state's at first, but not moving with it."""
    model = world.arm_model
    q_now = world.arm.state().q.copy()
    q_view = view_pose(model, world.cameras, q_now, np.random.default_rng(0))
    assert q_view is not None
    world.arm.command_trajectory(motions.slow_move(model, q_now, q_view))
    assert wait_while_moving(world.arm, world.clock, world.rig, timeout_s=30.0)
    result = probe_seen_moving(bad_drivers.EchoingArm(world.arm, world.clock), model, world.clock, rig_watch(world))
    figures = result.figures
    assert result.status == "fail", result.reason
    assert "the rig saw it move 0.0" in result.reason and figures["state_travel_m"] > 0.03, result.reason
    # it saw the LED, standing: its extent over the probe's ~260 frames is the triangulation's noise
    # (measured 9.8 mm with the LED 0.85 m from the rig, 4.7 mm at 0.6 m), under half the state's travel
    assert figures["rig_travel_m"] < bounds.RIG_TRAVEL_FRACTION_MIN * figures["state_travel_m"]
    assert figures["rig_travel_m"] < 0.015 and figures["frames_seen"] > 0


def test_the_kinematic_worlds_arm_passes_state_measured_and_seen_moving():
    """The kinematic world's `SimulatedArm` (its servo's state plus the tracking error the settings
    give it, 1 mrad) is measured, not echoed, and the rig sees it move as it says."""
    w = SimWorld(seed=3)
    w.connect()
    w.set_calibration(w.true_calibration())
    checks = _checks(run_checks(w.arm, w.arm_model, w.clock, gripper=None, watch=rig_watch(w)))
    w.close()
    for name in ("state measured", "seen moving"):
        assert checks[name].status == "pass" and not checks[name].warnings, (checks[name].reason, checks[name].warnings)
    assert checks["state measured"].figures["equal_to_command"] == 0
    seen = checks["seen moving"].figures  # measured: 0.8 mm RMS
    assert seen["error_rms_m"] < 0.5 * bounds.RIG_ERROR_RMS_MAX_M and seen["seen_fraction"] > 0.95


def test_without_a_calibrated_rig_seen_moving_is_not_run_and_the_report_does_not_pass():
    w = SimWorld(seed=3)
    assert rig_watch(w) is None  # not calibrated
    result = probe_seen_moving(w.arm, w.arm_model, w.clock, None)
    assert result.status == "not run" and result.reason == NO_RIG and "--calibration" in result.reason
    report = DriverReport("pa10", "lab:arm", "", "simulated", (result,))
    assert not report.passed and "FAILED (seen moving)" in report.table()


def test_a_host_timed_hand_passes_with_a_warning_in_the_table_and_the_json():
    clock = SimClock(0.0)
    host_timed = probe_hand(HostTimedHand(SimulatedGripper(clock, latency_s=0.01, stroke_s=0.02)), clock)
    assert host_timed.status == "pass" and host_timed.warnings == (HOST_TIMED_WARNING,)
    assert host_timed.figures["schedules_open"] is False
    assert "open_at" in HOST_TIMED_WARNING and "RELEASE_LATE_BOUND_S" in HOST_TIMED_WARNING
    scheduled = probe_hand(SimulatedGripper(clock, latency_s=0.01, stroke_s=0.02), clock)
    assert scheduled.status == "pass" and scheduled.warnings == () and scheduled.figures["schedules_open"] is True
    report = DriverReport("pa10", "lab:arm", "lab:hand", "simulated", (host_timed,))
    assert report.passed and "PASSED, 1 warning(s)" in report.table()
    assert "| WARN " in report.table() or " WARN " in report.table()
    document = json.loads(json.dumps(report.to_dict()))
    assert document["checks"][0]["status"] == "pass" and document["checks"][0]["warnings"] == [HOST_TIMED_WARNING]


@pytest.mark.slow
def test_check_driver_command_fails_an_echoing_driver_and_its_json_says_which_checks(tmp_path, monkeypatch, capsys):
    """Through the command, on the system clock: the settings name a lab's driver module (written
    here) whose arm echoes its commands; the rig is the MuJoCo world's, calibrated."""
    (tmp_path / "echo_lab.py").write_text(
        '"""A lab\'s arm driver that reports its commands as its state."""\n'
        "from tests.app.bad_drivers import echoing_arm as arm  # noqa: F401\n"
    )
    monkeypatch.syspath_prepend(str(tmp_path))
    settings = Settings.load(EXAMPLE).replace(arm_driver="echo_lab:arm", gripper_driver="")
    lab = tmp_path / "lab.json"
    settings.save(lab)
    calibration = mujoco_rig_calibration(tmp_path, settings)
    try:
        status = main(["check-driver", "--settings", str(lab), "--calibration", str(calibration), "--yes", "--json"])
    finally:
        sys.modules.pop("echo_lab", None)
    assert status == 1
    document = json.loads(capsys.readouterr().out)
    assert document["passed"] is False and document["arm_driver"] == "echo_lab:arm"
    failed = {c["name"]: c for c in document["checks"] if c["status"] == "fail"}
    assert {"state measured", "seen moving"} <= set(failed), failed
    assert "echoes its commands" in failed["state measured"]["reason"]
    assert failed["seen moving"]["figures"]["frames_seen"] == 0, failed["seen moving"]["reason"]
    assert Path(document["report_file"]).exists()


def test_frames_the_host_read_no_state_around_are_counted_not_judged(world):
    """A loaded host: one read of the arm in 50 comes 40 ms late (the clock runs on meanwhile, the
    remotes keep reporting). The frames in those gaps cannot be placed on the arm's path: they are
    counted as the host's, and the driver still passes."""

    class LateHost(bad_drivers.WrappedArm):
        reads = 0

        def state(self):
            self.reads += 1
            if self.reads % 50 == 0:
                self.clock.sleep(0.04)
            return self.inner.state()

        def set_marker_led(self, on: bool) -> None:
            self.inner.set_marker_led(on)

    result = probe_seen_moving(LateHost(world.arm, world.clock), world.arm_model, world.clock, rig_watch(world))
    assert result.status == "pass", result.reason
    assert result.figures["host_late_frames"] > 10 and "the host read no state around" in result.reason
    assert result.figures["frames_seen"] >= bounds.RIG_MIN_FRAMES
