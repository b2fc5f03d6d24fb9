"""The MuJoCo world's compiled servo cycle (`app/worlds/mujoco/cycle.py`) against the per-period
Python controller it replaces: the arm driver's velocity-mode law run compiled, many periods at a
time, gives the very motion (to the bit) and the very ball events that the driver's own
`VelocityModeArm._control`, called by the lab once per period, gives; the arm's reference for
many periods at once is the per-period one, a run that ends at a watched event takes back what it
did not reach, and the remotes that read at one step share the LEDs."""

from __future__ import annotations

import numpy as np
import pytest

from tests.helpers.per_step_arm import PerStepArm
from wiithrow.app.settings import Settings
from wiithrow.app.worlds.mujoco.devices import MujocoArm, MujocoGripper
from wiithrow.app.worlds.mujoco.lab import MujocoLab
from wiithrow.clock import SimClock
from wiithrow.robot import JointTrajectory, SimulatedArm, load_arm
from wiithrow.throwing import TRAINING_AREA, plan_throw, solve_throw


def throw_in(lab: MujocoLab, clock: SimClock, arm: MujocoArm, chunks: np.random.Generator | None) -> None:
    """Move to the start of a fast throw, grip, throw, open at the release, run 1.5 s more; the
    clock moves 1 ms at a time, or by random chunks of 1-30 ms (`chunks`)."""
    model = arm.arm_model
    corner = np.array([TRAINING_AREA.x[1], TRAINING_AREA.z[1]])
    plan = plan_throw(model, solve_throw(model, corner), float(corner[1]), q1=0.0)
    hand = MujocoGripper(lab)

    def run(seconds: float) -> None:
        end = clock.now() + seconds
        while clock.now() < end - 1e-9:
            step = 0.001 if chunks is None else 0.001 * int(chunks.integers(1, 31))
            clock.advance(min(step, end - clock.now()))
            lab.advance()

    arm.command_position(plan.trajectory.positions[0])
    run(3.0)
    hand.close()
    run(0.2)
    arm.command_trajectory(plan.trajectory)
    run(plan.release_time)
    hand.open()
    run(1.5)


def test_the_compiled_law_moves_the_arm_as_the_per_period_controller_does():
    settings = Settings()
    model = load_arm("pa10")
    runs = []
    for compiled in (True, False):
        clock = SimClock()
        lab = MujocoLab(settings, clock)
        arm = MujocoArm(model, clock, lab)
        if not compiled:
            lab.attach_host(arm._control)  # the driver's own controller, once per period from Python
        throw_in(lab, clock, arm, np.random.default_rng(3) if compiled else None)
        runs.append((lab, arm))
    (fast, fast_arm), (slow, slow_arm) = runs
    assert fast.t == slow.t
    for a, b in ((fast.data.qpos, slow.data.qpos), (fast.data.qvel, slow.data.qvel)):
        np.testing.assert_array_equal(a, b)
    np.testing.assert_array_equal(fast.servo.integral, slow.servo.integral)
    np.testing.assert_array_equal(fast_arm.last_command, slow_arm.last_command)
    assert fast.servo.saturated_steps == slow.servo.saturated_steps
    ev, ref = fast.events, slow.events
    # the ball left and came down, at the same steps, where the per-period run saw it
    assert ref.released_at is not None and ref.touchdown_at is not None and ref.touchdown is not None
    assert (ev.opened_at, ev.released_at, ev.touchdown_at) == (ref.opened_at, ref.released_at, ref.touchdown_at)
    np.testing.assert_array_equal(ev.touchdown, ref.touchdown)
    np.testing.assert_array_equal(ev.release_velocity, ref.release_velocity)
    assert ev.path_t == ref.path_t and len(ev.path_t) > 50
    np.testing.assert_array_equal(np.array(ev.path), np.array(ref.path))


@pytest.mark.parametrize("until", ["rest", "release"])
def test_the_arms_reference_for_many_periods_at_once_is_the_per_period_one(until):
    """`SimulatedArm.ideal_path` (the reference of a run's periods at once, vectorised) against
    the interpolator stepped one step at a time (`PerStepArm`'s `ideal_qv` after moving its clock): a real
    throw trajectory from rest to its follow-through's rest, or cut at its release at speed (then
    it continues into a brake, off the samples' grid), in runs of 1-100 periods, some taken back
    (`snapshot`/`restore`) and stepped again: the very numbers."""
    model = load_arm("pa10")
    corner = np.array([TRAINING_AREA.x[1], TRAINING_AREA.z[1]])
    plan = plan_throw(model, solve_throw(model, corner), float(corner[1]), q1=0.0)
    trajectory = plan.trajectory
    if until == "release":
        k = plan.release_index + 1
        trajectory = JointTrajectory(
            trajectory.times[:k], trajectory.positions[:k], trajectory.velocities[:k], trajectory.accelerations[:k]
        )
    q0 = trajectory.positions[0]
    clock_a, clock_b = SimClock(), SimClock()
    per_step, at_once = PerStepArm(model, clock_a, q0=q0), SimulatedArm(model, clock_b, q0=q0)
    for arm, clock in ((per_step, clock_a), (at_once, clock_b)):
        clock.advance(0.0105)  # commanded between periods
        arm.command_trajectory(trajectory)
    h = per_step.dt
    periods = int((trajectory.duration + 1.0) / h)
    times = 0.011 + np.arange(periods) * h
    expected_q, expected_v = [], []
    for t in times:
        clock_a.advance(t - clock_a.now())
        q, v = per_step.ideal_qv()
        expected_q.append(q.copy())
        expected_v.append(v.copy())
    rng = np.random.default_rng(5)
    got_q, got_v, taken_back, i = [], [], 0, 0
    while i < periods:
        n = min(int(rng.integers(1, 101)), periods - i)
        if rng.random() < 0.3 and n > 1:  # a run that ended early: take the rest back
            before = at_once.snapshot()
            at_once.ideal_path(times[i : i + n])
            at_once.restore(before)
            n = int(rng.integers(1, n))
            taken_back += 1
        q, v = at_once.ideal_path(times[i : i + n])
        got_q.append(q)
        got_v.append(v)
        i += n
    assert taken_back > 5
    np.testing.assert_array_equal(np.vstack(got_q), np.array(expected_q))
    np.testing.assert_array_equal(np.vstack(got_v), np.array(expected_v))
    assert not np.array_equal(expected_q[0], expected_q[-1])  # it moved ...
    assert per_step.command_kind == at_once.command_kind == ""  # ... and braked to rest
    assert per_step.saturated_steps == at_once.saturated_steps
    # the throw, and the brake it went on into
    assert per_step.commands_started == at_once.commands_started == (1 if until == "rest" else 2)


def test_a_run_that_ends_at_the_release_takes_back_the_reference_it_did_not_reach(monkeypatch):
    """The lab runs many periods while the ball is watched and stops at the event; the arm then
    puts its interpolator back (`SimulatedArm.restore`) to the last period that ran: it is never
    ahead of the physics afterwards, and its reference there is the per-period one."""
    restores = []
    original = SimulatedArm.restore

    def counted(self, snapshot):
        restores.append(self)
        original(self, snapshot)

    monkeypatch.setattr(SimulatedArm, "restore", counted)
    clock = SimClock()
    lab = MujocoLab(Settings(), clock)
    arm = MujocoArm(load_arm("pa10"), clock, lab)
    throw_in(lab, clock, arm, np.random.default_rng(3))
    assert lab.events.released_at is not None and lab.events.touchdown_at is not None
    assert restores and all(r is arm.interpolator for r in restores)  # the release ended a run early
    assert arm.interpolator.ideal_state().t <= lab.t + 1e-12  # not ahead of the physics


def test_the_remotes_reading_at_one_step_share_the_leds_and_a_change_shows_at_once():
    """`leds_in_link1` computes the LEDs once per physics step for the remotes that read then, and
    still shows a target placed, lit or covered at that very step (the numbers of a fresh numpy
    computation, R^T (p - o) in the true link1, to a last bit: the lab's are plain floats)."""
    clock = SimClock()
    lab = MujocoLab(Settings(), clock)
    names = ("marker", "target", "landing")
    clock.advance(0.05)
    lab.set_led("marker", True)
    first = lab.leds_in_link1(names)
    first[0] = 99.0  # a caller's copy: writing it changes nothing for the next remote
    second = lab.leds_in_link1(names)
    R, o = lab.link1_pose()
    marker = R.T @ (lab.data.site_xpos[lab.built.sites["marker_led"]] - o)
    np.testing.assert_allclose(second[0], marker, rtol=0, atol=1e-15)
    assert np.isnan(second[1:]).all()  # target and landing off
    lab.set_led("marker", False)
    lab.place_target([1.2, 0.1, 0.3])
    lab.set_led("target", True)  # at the same step
    third = lab.leds_in_link1(names)
    R, o = lab.link1_pose()  # (placing the table recomputed the kinematics: mj_forward)
    target = R.T @ (lab.data.site_xpos[lab.built.sites["target_led"]] - o)
    assert np.isnan(third[0]).all() and np.isnan(third[2]).all()
    np.testing.assert_allclose(third[1], target, rtol=0, atol=1e-15)
    np.testing.assert_allclose(R @ third[1] + o, [1.2, 0.1, 0.3], atol=1e-12)
    lab.place_target([1.0, -0.2, 0.25])  # moved, still lit, same step
    np.testing.assert_allclose(R @ lab.leds_in_link1(names)[1] + o, [1.0, -0.2, 0.25], atol=1e-12)


@pytest.mark.parametrize("lit", ["target", "marker"])  # the target stands still; the hand's LED moves
def test_a_report_read_late_shows_the_leds_where_they_were_at_its_time(lit):
    """A remote whose report falls due inside a long run (a real-time world catching up after its host
    was not scheduled) sees the LEDs where they were at the report's time, from the ring of the steps'
    poses: the very rows a lab read at that time gives, while joints 1 and 2 turn by tenths of a
    radian in between (before, every such report showed the pose at the end of the run: under a
    load of 8 the real-time MuJoCo world triangulated the two remotes' mismatched views 15-40 cm off
    and lost its target in 9 of 12 first alignments; 0 of 10 with the ring)."""
    names = ("marker", "target", "landing")
    q = load_arm("pa10").home.copy()
    q[:2] += 0.3  # joint 1 turns the rig (the target moves in link1), joint 2 the hand in it
    late_reads = np.arange(0.02, 0.4, 0.01)
    rows = []
    for late in (False, True):
        clock = SimClock()
        lab = MujocoLab(Settings(), clock)
        arm = MujocoArm(load_arm("pa10"), clock, lab)
        lab.place_target([1.3, 0.1, 0.2])
        lab.set_led(lit, True)  # (the operator covers the target while the hand's LED is on)
        arm.command_position(q)
        if late:  # the clock runs 0.4 s, then the reports of that time are made
            clock.advance(0.4)
            lab.advance()
            rows.append([lab.leds_in_link1(names, t) for t in late_reads])
        else:
            got = []
            for t in late_reads:
                clock.advance(t - clock.now())
                got.append(lab.leds_in_link1(names, t))
            rows.append(got)
    on_time, read_late = np.array(rows[0]), np.array(rows[1])
    np.testing.assert_array_equal(read_late, on_time)
    # and the rig did turn meanwhile: the LED moved across link1 by more than 1 cm
    seen = on_time[:, names.index(lit)]
    assert np.isfinite(seen).all() and np.ptp(seen, axis=0).max() > 0.01, seen


def test_the_leds_in_plain_floats_give_the_remotes_the_pixels_of_numpys_leds():
    """The lab's LEDs in link1 (`_leds_in_link1_floats`, plain floats) against numpy's R^T (p - o)
    at every step of a throw: within 1e-15 m (BLAS's fused multiply-adds round a last bit
    differently), and the same integer pixels in both remotes of the default rig, noise drawn alike."""
    from wiithrow.app.worlds.mujoco.model import link1_pose
    from wiithrow.vision.rig import stereo_rig

    clock = SimClock()
    lab = MujocoLab(Settings(), clock)
    arm = MujocoArm(load_arm("pa10"), clock, lab)
    names = ("marker", "target", "landing")
    lab.place_target([1.3, 0.1, 0.2])
    lab.set_led("target", True)
    cameras = stereo_rig()
    gaps, pixels_differ, observed = [], 0, 0
    step = lab.advance

    def advance_and_compare() -> None:
        step()
        shown = tuple(lab._shows(name) for name in names)
        mine = np.array(lab._leds_in_link1_floats(names, shown))
        R, o = link1_pose(lab.built, lab.data)
        numpy_rows = np.array(
            [
                R.T @ (lab.data.site_xpos[lab.built.sites[f"{n}_led"]] - o) if on else np.full(3, np.nan)
                for n, on in zip(names, shown, strict=True)
            ]
        )
        gaps.append(np.nanmax(np.abs(mine - numpy_rows)))
        nonlocal pixels_differ, observed
        for c, camera in enumerate(cameras):
            seed = [len(gaps), c]
            a = camera.observe_few(mine.tolist(), np.random.default_rng(seed))
            b = camera.observe_few(numpy_rows.tolist(), np.random.default_rng(seed))
            pixels_differ += a != b
            observed += sum(p is not None for p in a[0])

    lab.advance = advance_and_compare  # type: ignore[method-assign]
    throw_in(lab, clock, arm, np.random.default_rng(5))
    assert len(gaps) > 200 and observed > 200  # the target seen all along
    assert max(gaps) <= 1e-15
    assert pixels_differ == 0
