"""A late host is the host's, never the driver's: `wiithrow check-driver` on the MuJoCo drivers with a
host that wakes its thread late (a simulated clock whose sleeps overshoot, as a host at load 10 did:
"a new sample every inf ms ... 1 reads gave 1 samples", "the host read the hand too late" failed the
project's own drivers) gives no driver FAIL: the checks whose figures the lateness distorts are
tried again and then reported as not run, with how late the host woke; the others pass on what
they measured. A bad driver on the same late host still fails the check that is about its fault.
"""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from tests.app import bad_drivers
from tests.app.test_check_driver import LateWakingClock
from wiithrow.app.drivercheck import bounds
from wiithrow.app.drivercheck.host import HOST_LATE_S, HOST_TRIES, HostWatch, retried
from wiithrow.app.drivercheck.procedure import CHECK_NAMES, run_checks
from wiithrow.app.drivercheck.report import CheckResult
from wiithrow.app.drivercheck.rig_probe import probe_seen_moving, rig_watch
from wiithrow.app.settings import Settings
from wiithrow.app.worlds.mujoco import drivers
from wiithrow.app.worlds.mujoco.world import MujocoWorld
from wiithrow.clock import SimClock

EXAMPLE = Path(__file__).resolve().parents[2] / "examples" / "mujoco_settings.json"


def _checks(clock: SimClock, arm_driver=drivers.arm) -> dict[str, CheckResult]:
    settings = Settings.load(EXAMPLE)
    model = settings.load_arm()
    arm, hand = arm_driver(model, clock, settings), drivers.gripper(model, clock, settings)
    return dict(zip(CHECK_NAMES, run_checks(arm, model, clock, gripper=hand), strict=True))


@pytest.mark.parametrize("every", [1, 7])
def test_a_host_that_wakes_30_ms_late_fails_no_check_of_a_good_driver(every):
    """Every sleep (and one in seven) of the check's thread wakes 30 ms late."""
    checks = _checks(LateWakingClock(every=every, late_s=0.03))
    failed = {name: c.reason for name, c in checks.items() if c.status == "fail"}
    assert not failed, failed
    host = {name: c for name, c in checks.items() if c.status == "not run" and "the host was late" in c.reason}
    # the hand's release cannot be timed by a host that reads it 30 ms apart: said, with the gaps
    assert (
        "hand" in host and "by up to 30 ms" in host["hand"].reason and "not a fault of the hand" in host["hand"].reason
    )
    if every == 1:  # nor the state's rate: 18 reads in 0.5 s, each 30 ms after the one before
        assert "state" in host and "tries" in host["state"].reason
        assert re.search(r"woke up to 30\.\d ms late from its sleeps", host["state"].reason), host["state"].reason
        assert host["state"].figures["host_tries"] == HOST_TRIES
    else:  # one sleep in seven: the driver's 1 kHz measured on the steps the host read on time
        assert checks["state"].status == "pass" and checks["state"].figures["sample_rate_hz"] == pytest.approx(1000.0)
    for name in ("slow motion", "stop", "scaled throw", "throwing speed"):  # timed by the driver's own stamps
        assert checks[name].status == "pass", f"{name}: {checks[name].reason}"


def test_a_stale_driver_on_a_late_host_still_fails_its_state():
    checks = _checks(LateWakingClock(every=7, late_s=0.03), bad_drivers.stale_arm)
    state = checks["state"]
    # (it refreshes at the first read 100 ms after its last sample: a late host reads it later)
    stale = re.search(r"stale state: a new sample every (\d+) ms", state.reason)
    assert state.status == "fail" and stale and 100 <= int(stale.group(1)) <= 135, state.reason
    assert "host_late" not in state.figures


def test_a_failure_the_host_explains_is_tried_again_then_not_run():
    clock = SimClock(0.0)
    watch = HostWatch(clock)
    mark = watch.mark()
    watch.sleep(0.001)
    clock.advance(0.0)  # on time
    assert not watch.since(mark).late
    late = LateWakingClock(every=1, late_s=0.02)
    watch = HostWatch(late)
    mark = watch.mark()
    watch.sleep(0.001)
    lateness = watch.since(mark)
    assert lateness.late and lateness.worst_wake_s == pytest.approx(0.02) and lateness.late_wakes == 1
    assert lateness.worst_wake_s >= HOST_LATE_S and lateness.cpu_wait_s is None  # simulated time: no CPU wait
    runs = []

    def host_failure() -> CheckResult:
        runs.append(1)
        return CheckResult("state", "fail", "stale state", {"host_late": "it read the arm every 30 ms"})

    result = retried("state", host_failure, watch, lambda line: None)
    assert len(runs) == HOST_TRIES and result.status == "not run"
    assert "the host was late in 3 tries (it read the arm every 30 ms)" in result.reason
    driver_failure = CheckResult("state", "fail", "stale state", {})
    assert retried("state", lambda: driver_failure, watch, lambda line: None) is driver_failure


def test_a_host_that_reads_no_state_around_the_rigs_frames_is_the_hosts_not_the_arms():
    """The rig keeps seeing the LED while the host reads the arm 60 ms apart: the frames it read no
    state around are not judged, and too few left to judge is the host's (tried again), not a
    driver that is not where its state says."""
    world = MujocoWorld(Settings.load(EXAMPLE), seed=3)
    world.connect()
    world.set_calibration(world.true_calibration())

    class LateHost(bad_drivers.WrappedArm):
        def state(self):
            self.clock.sleep(0.06)
            return self.inner.state()

        def set_marker_led(self, on: bool) -> None:
            self.inner.set_marker_led(on)

    result = probe_seen_moving(LateHost(world.arm, world.clock), world.arm_model, world.clock, rig_watch(world))
    world.close()
    assert result.status == "fail" and result.figures["frames_in_view"] < bounds.RIG_MIN_FRAMES, result.reason
    assert result.figures["host_late_frames"] > bounds.RIG_MIN_FRAMES
    assert result.figures["host_late"].startswith("it read no state around"), result.figures
