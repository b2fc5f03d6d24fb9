"""`wiithrow check-driver` (`wiithrow.app.drivercheck`): the MuJoCo world's drivers pass every
check, with no throw library (the throws are planned from the arm's model); three deliberately bad
drivers (`tests.app.bad_drivers`: 50 ms late, ignoring Stop, stale state) are each caught by the
check that is about their fault, with the reason, while the other checks judge what they measured. The probes run on a `SimClock` (the MuJoCo drivers step their
physics to whatever clock they are given), so a full check takes a few seconds; the command
itself runs on the system clock as `serve` does (marked slow: 20 s of real motion).
"""

from __future__ import annotations

import json
import re
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from tests.app import bad_drivers
from tests.helpers.host_timed_hand import HostTimedHand
from wiithrow.app.cli.main import main
from wiithrow.app.drivercheck import bounds
from wiithrow.app.drivercheck.hand_probe import probe_hand
from wiithrow.app.drivercheck.probes import probe_scaled_throw
from wiithrow.app.drivercheck.procedure import CHECK_NAMES, run_checks
from wiithrow.app.drivercheck.report import CheckResult, DriverReport
from wiithrow.app.drivercheck.rig_probe import rig_watch
from wiithrow.app.drivercheck.store import cached_report_path, driver_report_status, report_path_for, save_report
from wiithrow.app.settings import Settings
from wiithrow.app.worlds.mujoco.world import MujocoWorld
from wiithrow.clock import SimClock
from wiithrow.robot import load_arm
from wiithrow.robot.gripper import SimulatedGripper

EXAMPLE = Path(__file__).resolve().parents[2] / "examples" / "mujoco_settings.json"


@pytest.fixture(scope="module")
def settings() -> Settings:
    return Settings.load(EXAMPLE)


def _model(settings: Settings):
    return load_arm(settings.arm, marker_offset=settings.marker_offset_m, ball_offset=settings.ball.offset_m)


def _by_name(results) -> dict[str, CheckResult]:
    assert tuple(r.name for r in results) == CHECK_NAMES
    return {r.name: r for r in results}


def test_the_mujoco_drivers_pass_every_check(settings):
    """The MuJoCo world's drivers, its rig calibrated (the true cameras) watching the hand's LED;
    no throw library: the throws are planned from the arm's model."""
    world = MujocoWorld(settings, seed=3)
    world.connect()
    world.set_calibration(world.true_calibration())
    arm, model, clock = world.arm, world.arm_model, world.clock
    q_start = arm.state().q
    checks = _by_name(run_checks(arm, model, clock, gripper=world.gripper, ball=world.ball(), watch=rig_watch(world)))
    world.close()
    for check in checks.values():
        assert check.status == "pass" and not check.warnings, f"{check.name}: {check.reason} {check.warnings}"
    measured = checks["state measured"].figures  # a servo's state: no sample equals a commanded one
    assert measured["moving_states"] > 1000 and measured["equal_to_command"] == 0 and measured["repeated_pairs"] == 0
    assert measured["rest_spread_max_rad"] > 0.0
    seen = checks["seen moving"].figures  # the rig saw the LED where the state put it (measured: 6.1 mm RMS)
    assert seen["frames_in_view"] >= bounds.RIG_MIN_FRAMES and seen["seen_fraction"] >= bounds.RIG_SEEN_FRACTION_MIN
    assert seen["error_rms_m"] <= bounds.RIG_ERROR_RMS_MAX_M and seen["host_late_frames"] == 0
    assert seen["rig_travel_m"] >= bounds.RIG_TRAVEL_FRACTION_MIN * seen["state_travel_m"] > 0.03
    state = checks["state"].figures
    assert state["sample_rate_hz"] == pytest.approx(1000.0)  # the servo's 1 kHz
    assert state["age_median_s"] <= bounds.STATE_AGE_MEDIAN_MAX_S and state["age_min_s"] >= bounds.STATE_AGE_MIN_S
    throw = checks["scaled throw"].figures
    assert throw["rms_rad"] <= bounds.THROW_RMS_MAX_RAD and throw["max_rad"] <= bounds.THROW_MAX_MAX_RAD
    assert abs(throw["lag_s"]) <= bounds.LAG_MAX_S
    assert throw["peak_speed_of_limit"] == pytest.approx(0.95 / bounds.THROW_TIME_SCALE, abs=0.01)
    speed = checks["throwing speed"].figures  # every throwing joint at its planned peak (measured: 100 %)
    assert speed["joints"] == ["S2", "E1", "W1"] and min(speed["reached_of_planned"]) >= 0.97
    assert min(speed["planned_of_limit"]) >= bounds.THROW_SPEED_FRACTION - 0.01
    stop = checks["stop"].figures
    assert stop["to_rest_s"] <= stop["ideal_brake_s"] + bounds.STOP_SETTLE_MAX_S
    assert stop["beyond_ideal_brake_end_rad"] <= bounds.STOP_OVERSHOOT_MAX_RAD
    assert checks["limits refused"].figures["refused_with_limit_error"] == 2 * model.nq
    hand = checks["hand"].figures
    assert hand["cycles"] == bounds.HAND_CYCLES and hand["release"] == "open_at" and hand["tells_holding"]
    # the MuJoCo hand: 10 ms latency + 3 ms jitter (settings.mujoco) before the fingers move and the ball is free
    for name in ("part", "free"):
        assert settings.mujoco.release_latency_s <= hand[f"{name}_median_s"] <= bounds.HAND_RELEASE_MAX_S
        assert 0.0 < hand[f"{name}_jitter_s"] <= bounds.HAND_JITTER_MAX_S
    # the check leaves the arm where it found it, at rest
    assert np.max(np.abs(arm.state().q - q_start)) < 0.003 and not arm.is_moving()


def test_the_hand_check_times_the_release_the_way_a_throw_releases():
    """A hand that schedules its open is timed from the time it was given (`open_at`), a host-timed
    one from its `open()`: the jaws part after its latency, seen within a poll."""
    clock = SimClock(0.0)
    stroke, latency = 0.02, 0.01  # the jaws part (2 % of the stroke) after latency + 0.02 stroke
    expected = latency + bounds.HAND_PART_OPENING * stroke
    for hand, release in (
        (SimulatedGripper(clock, latency_s=latency, stroke_s=stroke), "open_at"),
        (HostTimedHand(SimulatedGripper(clock, latency_s=latency, stroke_s=stroke)), "open"),
    ):
        result = probe_hand(hand, clock)
        assert result.status == "pass" and result.figures["release"] == release, result.reason
        part = np.array(result.figures["part_times_s"])
        assert part.size == bounds.HAND_CYCLES and np.all(np.abs(part - expected) <= bounds.POLL_S + 1e-9), part
        open_times = np.array(result.figures["open_times_s"])  # 90 % of the stroke
        assert np.all(np.abs(open_times - (latency + 0.9 * stroke)) <= bounds.POLL_S + 1e-9), open_times


class LateWakingClock(SimClock):
    """A loaded host on a simulated clock: a sleep wakes `late_s` late, one in `every` at random
    (seeded; every one at 1)."""

    def __init__(self, every: int, late_s: float = 0.03, seed: int = 0) -> None:
        super().__init__(0.0)
        self.every, self.late_s, self.sleeps = every, late_s, 0
        self.rng = np.random.default_rng(seed)

    def sleep(self, seconds: float) -> None:
        self.sleeps += 1
        late = self.every == 1 or self.rng.integers(self.every) == 0
        super().sleep(seconds + (self.late_s if late else 0.0))


def test_a_host_that_reads_the_hand_late_does_the_cycle_again_instead_of_timing_it():
    stroke, latency = 0.02, 0.01
    expected = latency + bounds.HAND_PART_OPENING * stroke
    # one sleep in 100 (50 ms of 0.5-ms polls) wakes 30 ms late: the cycles whose release fell in
    # such a gap (about one in three) are done again
    clock = LateWakingClock(every=100)
    result = probe_hand(SimulatedGripper(clock, latency_s=latency, stroke_s=stroke), clock)
    assert result.status == "pass", result.reason
    figures = result.figures
    assert figures["host_late_cycles"] >= 1 and figures["cycles"] == bounds.HAND_CYCLES
    timed = np.array(figures["part_times_s"])
    assert timed.size == bounds.HAND_CYCLES and np.all(np.abs(timed - expected) <= bounds.POLL_S + 1e-9), timed
    # a host late at every read cannot time the hand at all: it says so, and blames no driver
    clock = LateWakingClock(every=1)
    result = probe_hand(SimulatedGripper(clock, latency_s=latency, stroke_s=stroke), clock)
    assert result.status == "not run" and "the host was late" in result.reason, result.reason
    assert "not a fault of the hand" in result.reason and result.figures["host_late_cycles"] > bounds.HAND_CYCLES


def _bad(factory, settings):
    clock = SimClock(0.0)
    model = _model(settings)
    arm = factory(model, clock, settings)
    return _by_name(run_checks(arm, model, clock, gripper=None)), arm, model, clock


def test_a_driver_50_ms_late_fails_following_with_its_lag(settings):
    checks, arm, model, clock = _bad(bad_drivers.lagging_arm, settings)
    slow = checks["slow motion"]
    assert slow.status == "fail" and "lags its command by" in slow.reason
    assert slow.figures["lag_s"] == pytest.approx(bad_drivers.LAG_S, abs=0.003)
    for name in ("state", "limits refused", "stop"):  # judged on what they measured: nothing wrong there
        assert checks[name].status == "pass", f"{name}: {checks[name].reason}"
    assert checks["scaled throw"].status == "not run" and "slow motion" in checks["scaled throw"].reason
    assert checks["hand"].status == "not run"
    # which term is missing, measured: a delay, not the controller's feed-forward
    assert "ms late, a delay" in slow.reason and "a queue" in slow.reason, slow.reason
    assert slow.figures["diagnosis"]["lag_model"]["delay_s"] == pytest.approx(bad_drivers.LAG_S, abs=0.006)
    # the throw, had it been given one: late by the same 50 ms at the release
    throw = probe_scaled_throw(arm, model, clock)
    assert throw.status == "fail" and "at the release" in throw.reason
    assert throw.figures["lag_s"] == pytest.approx(bad_drivers.LAG_S, abs=0.003)
    assert throw.figures["rms_rad"] > bounds.THROW_RMS_MAX_RAD


def test_a_driver_that_ignores_stop_fails_stop(settings):
    checks, *_ = _bad(bad_drivers.stop_ignoring_arm, settings)
    stop = checks["stop"]
    assert stop.status == "fail" and "ignored Stop" in stop.reason
    assert not np.isfinite(stop.figures["to_rest_s"])
    # it ran on to the move's end, 0.4 rad out, far past where a brake within the limits ends
    assert stop.figures["beyond_ideal_brake_end_rad"] > 10 * bounds.STOP_OVERSHOOT_MAX_RAD
    for name in ("state", "slow motion", "limits refused"):
        assert checks[name].status == "pass", f"{name}: {checks[name].reason}"
    assert checks["scaled throw"].status == "not run" and "stop" in checks["scaled throw"].reason


def test_a_driver_with_stale_state_fails_state(settings):
    checks, *_ = _bad(bad_drivers.stale_arm, settings)
    state = checks["state"]
    assert state.status == "fail" and "stale state" in state.reason and "old state" in state.reason
    assert state.figures["sample_period_s"] == pytest.approx(bad_drivers.STALE_S, abs=0.002)
    assert state.figures["age_median_s"] == pytest.approx(bad_drivers.STALE_S / 2, abs=0.01)
    # each sample it does give is true at its timestamp: the following and the Stop pass on them
    for name in ("slow motion", "limits refused", "stop"):
        assert checks[name].status == "pass", f"{name}: {checks[name].reason}"
    assert checks["scaled throw"].status == "not run" and "state" in checks["scaled throw"].reason


# ----- reports: where they are kept, and what serve says -----------------------------------------


def _report(settings: Settings, passed: bool) -> DriverReport:
    status = "pass" if passed else "fail"
    checks = (CheckResult("state", "pass", "ok"), CheckResult("stop", status, "ignored Stop"))
    return DriverReport(settings.arm, settings.arm_driver, settings.gripper_driver, "system", checks)


def test_driver_report_status_finds_passing_reports_of_these_drivers_only(tmp_path, settings):
    path = tmp_path / "lab.json"
    settings.save(path)
    assert driver_report_status(Settings()) is None  # no arm driver: nothing to check
    missing = driver_report_status(settings, path)
    assert missing is not None and "no passing driver report" in missing and "check-driver" in missing
    save_report(_report(settings, False), report_path_for(path))
    failed = driver_report_status(settings, path)
    assert failed is not None and "did not pass: stop" in failed
    other = settings.replace(arm_driver="tests.app.bad_drivers:stale_arm")
    save_report(_report(other, True), report_path_for(path))  # a report of other drivers does not count
    assert driver_report_status(settings, path) is not None
    save_report(_report(settings, True), report_path_for(path))
    assert report_path_for(path) == tmp_path / "lab.driver-report.json"
    assert driver_report_status(settings, path) is None
    # the cache serves any settings file naming the same drivers
    assert driver_report_status(settings, tmp_path / "elsewhere.json") is not None
    save_report(_report(settings, True), cached_report_path(settings))
    assert driver_report_status(settings, tmp_path / "elsewhere.json") is None
    cached_report_path(settings).unlink()


def test_serve_warns_at_start_when_the_arm_driver_has_no_passing_report(tmp_path, capsys):
    path = tmp_path / "lab.json"
    Settings(arm_driver="no_such_lab_module:arm").save(path)
    assert main(["serve", "--settings", str(path), "--port", "0"]) == 2  # the driver does not load
    err = capsys.readouterr().err
    assert "wiithrow serve: warning: arm_driver 'no_such_lab_module:arm' has no passing driver report" in err
    assert "cannot import 'no_such_lab_module'" in err


def test_check_driver_refuses_before_anything_moves(tmp_path, capsys):
    empty = tmp_path / "none.json"
    Settings().save(empty)
    assert main(["check-driver", "--settings", str(empty), "--yes"]) == 2
    assert "names no arm_driver" in capsys.readouterr().err
    lab = tmp_path / "lab.json"
    shutil.copy(EXAMPLE, lab)
    assert main(["check-driver", "--settings", str(lab)]) == 2  # no terminal to confirm on, no --yes
    assert "needs a confirmation" in capsys.readouterr().err
    assert not report_path_for(lab).exists()


def host_was_late(check: dict) -> bool:
    """A check the host was too late to judge (not run, saying how late it was): what a starved
    thread of the check gives on a loaded host, not a fault of the driver."""
    return check["status"] == "not run" and "the host was late" in check["reason"]


#: The niceness the real-time check of the MuJoCo drivers runs at, where the host allows it (root,
#: CAP_SYS_NICE; CI runs as root): as a lab runs an arm's real-time controller above the rest of
#: the machine. The simulated arm's state sampler and hand step on the host's clock; beside the
#: suite's other workers and four busy loops (a load of about 8 on two cores) they were starved at
#: nice 0 (the state unchanged for 1.1 s, scheduled opens 14-39 ms apart on both tries): the host's
#: failure, not the driver's, and no test of the check.
CONTROLLER_NICE = -10


def mujoco_rig_calibration(folder: Path, settings: Settings) -> Path:
    """The MuJoCo rig's calibration (its true cameras, in link1) as a file for `--calibration`: the
    rig of `wiithrow.app.worlds.mujoco.drivers:remotes` is mounted as these settings say."""
    world = MujocoWorld(settings)
    path = world.true_calibration().save(folder / "rig.calibration.json")
    world.close()
    return path


def check_driver_command(lab: Path, *flags: str) -> tuple[int, dict]:
    """`wiithrow check-driver --settings lab --yes --json [flags]` as its user runs it: a process of its own
    (every thread of it at `CONTROLLER_NICE`, through nice(1), which runs it at the niceness it has
    when it may not lower it, and says so on stderr). In this worker's process, at -10 for the
    calling thread only, it once failed on a quiet fresh clone at the busy start of the suite (the
    scheduled opens 23 ms apart on both tries): the worker's other threads were not at -10."""
    command = ["nice", "-n", str(CONTROLLER_NICE), sys.executable, "-m", "wiithrow.app.cli.main"]
    done = subprocess.run(
        [*command, "check-driver", "--settings", str(lab), "--yes", "--json", *flags],
        capture_output=True,
        text=True,
        timeout=600,
    )
    return done.returncode, json.loads(done.stdout)


@pytest.mark.slow
@pytest.mark.parametrize("example", ["mujoco_settings.json", "mujoco_panda_settings.json"])
def test_check_driver_command_on_the_mujoco_drivers_in_real_time(tmp_path, example):
    """The PA-10's and the Panda's MuJoCo drivers, no throw library given (none is needed)."""
    lab = tmp_path / "lab.json"
    shutil.copy(EXAMPLE.with_name(example), lab)
    calibration = str(mujoco_rig_calibration(tmp_path, Settings.load(lab)))
    status, document = check_driver_command(lab, "--calibration", calibration)
    if status != 0 and all(host_was_late(c) for c in document["checks"] if c["status"] != "pass"):
        # The MuJoCo world steps on this host in real time: on a host loaded past its cores (a suite
        # beside four busy loops) the hand's release could not be timed (read 10-40 ms apart) and
        # was not run. Once more, as its user would; that one must pass.
        print("the host was late:", [c["reason"] for c in document["checks"]], file=sys.stderr)
        status, document = check_driver_command(lab, "--calibration", calibration)
    assert status == 0, [(c["name"], c["status"], c["reason"]) for c in document["checks"] if c["status"] != "pass"]
    assert document["passed"] is True and document["clock"] == "system"
    assert [c["name"] for c in document["checks"]] == list(CHECK_NAMES)
    assert all(c["status"] == "pass" for c in document["checks"]), [c["reason"] for c in document["checks"]]
    written = json.loads(report_path_for(lab).read_text())
    assert written["kind"] == "wiithrow.driver-report" and written["passed"] is True
    assert Path(document["cached_report_file"]).exists()
    assert driver_report_status(Settings.load(lab), lab) is None


@pytest.mark.slow
def test_check_driver_command_on_a_bad_driver_fails_and_serve_is_warned(tmp_path, capsys):
    lab = tmp_path / "lab.json"
    settings = Settings.load(EXAMPLE).replace(arm_driver="tests.app.bad_drivers:stale_arm")
    settings.save(lab)
    assert main(["check-driver", "--settings", str(lab), "--yes"]) == 1
    out = capsys.readouterr().out
    failed = set(re.search(r"FAILED \(([^)]*)\)", out).group(1).split(", "))
    # the state check catches it and the throw is not run; a loaded host may also see its stale
    # samples fail another motion check (limits refused; slow motion, whose lag is fitted to a few
    # samples each 100 ms old at worst: 8.5 ms against 5 in a suite run), which is honest for this driver
    assert {"state", "scaled throw"} <= failed and "stale state" in out, out
    written = json.loads(report_path_for(lab).read_text())
    assert written["passed"] is False
    arm_checks = [c for c in written["checks"] if c["name"] != "hand"]  # the hand is the MuJoCo one
    arm_failed = {c["name"]: c for c in arm_checks if c["status"] == "fail"}
    assert "state" in arm_failed and set(arm_failed) <= {"state", "slow motion", "limits refused"}, arm_failed
    if "slow motion" in arm_failed:  # on the figures the stale samples distort, measured all the same
        reason = arm_failed["slow motion"]["reason"]
        assert re.match(r"(RMS error|largest error|lags its command|leads its command) ", reason), reason
        assert "could not be measured" not in reason and "nothing to judge" not in reason, reason
    if "limits refused" in arm_failed:  # only through a stale first sample: every command refused
        figures = arm_failed["limits refused"]["figures"]
        assert figures["accepted"] == [] and figures["refused_otherwise"] == [], figures
        assert figures["refused_with_limit_error"] == figures["commands"], figures
    for name in ("scaled throw", "throwing speed"):
        assert next(c for c in arm_checks if c["name"] == name)["status"] == "not run"
    status = driver_report_status(settings, lab)
    # serve's warning names every check that did not pass, in the report's order: state and the
    # two throws, and the motion checks between them that the loaded host failed too (and the
    # MuJoCo hand's, not run when a loaded host read it too late to time its release);
    # "seen moving" is not run: no --calibration, no rig to watch the arm
    not_passed = [c["name"] for c in written["checks"] if not c.get("passed")]
    allowed = {"state", "slow motion", "limits refused", "seen moving", "scaled throw", "throwing speed", "hand"}
    assert {"state", "seen moving", "scaled throw", "throwing speed"} <= set(not_passed) <= allowed, not_passed
    assert next(c for c in written["checks"] if c["name"] == "seen moving")["status"] == "not run"
    assert status is not None and f"did not pass: {', '.join(not_passed)};" in status, status
