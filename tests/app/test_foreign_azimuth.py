"""Why a lab's throws seemed to miss by where joint 1 turned, on the PD Panda with the weak slow hand
(tests/data/foreign_worlds/panda_pd): measured in the MuJoCo world, which knows the truth.

* Where joint 1 turned does not move the landing: the same target thrown at 0 and +-15 degrees
  (the session's alignment, preview and throw, each from home at rest, as `throw` runs them) lands
  within 2 mm along the throw of the target it was planned to; the ball sits in the hand at the
  release within 0.5 mm of where it sat at the other azimuths (the procedure loads it after the
  alignment: it never rides the joint-1 turn in the hand), and the arm tracks its plan at the
  release within 1.5 mrad of the other azimuths' (the arm has settled after the turn: the wind-up
  is planned from rest, `HostArm.is_moving`).
* The hand's delay does: the scatter of the lab's throws (median 22 mm, p95 47 mm, per-azimuth
  medians 32 mm apart over 15 throws on the hardware path) is the release's timing. The hand opens
  10 +- 3 ms after it is told; told at the plan's release, the ball leaves in the follow-through,
  which brakes at the arm's jerk limits from that instant, so every millisecond of the hand's
  jitter moves the landing by centimetres (below), and a handful of throws per azimuth gives
  medians far apart by chance. Told `hand_open_lead_s` early (the hand's latency and twice its
  jitter, the lab's settings), the ball leaves at the end of the acceleration, where the
  speed is flat, and the same delays move the landing by millimetres.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest

from wiithrow.app.rig.waiting import pump
from wiithrow.app.session import Session
from wiithrow.app.settings import Settings
from wiithrow.app.throws.execution import execute_throw, planning_start, return_home
from wiithrow.app.throws.training import train_in_world
from wiithrow.app.worlds.mujoco.world import MujocoWorld
from wiithrow.throwing import training_targets
from wiithrow.throwing.arm_throwing import training_area
from wiithrow.throwing.limiting import plan_throw
from wiithrow.throwing.operator import solve_throw
from wiithrow.throwing.validator import require_valid

SETTINGS = Path(__file__).resolve().parents[1] / "data" / "foreign_worlds" / "panda_pd" / "settings.json"


def lab(*, jitter_s: float = 0.0, lead_s: float | None = None) -> Settings:
    """The lab's settings, the hand's jitter and the throw's lead replaced."""
    s = Settings.load(SETTINGS)
    s = s.replace(mujoco=dataclasses.replace(s.mujoco, release_jitter_s=jitter_s))
    return s if lead_s is None else s.replace(hand_open_lead_s=lead_s)


def test_where_joint_1_turned_does_not_move_the_landing():
    world = MujocoWorld(lab(), seed=3)  # no jitter: what differs between the azimuths is the azimuth
    world.set_calibration(world.true_calibration())
    world.connect()
    pump(world.clock, world.rig, 0.2, step_s=0.01)
    area = training_area(world.arm_model)
    library = train_in_world(world, np.random.default_rng(0), targets=training_targets(area, nx=3, nz=3))
    session = Session(world, library=library, rng=np.random.default_rng(1), learn=False)
    session.use_calibration(world.true_calibration())
    x, z = library.throws[4].landing  # the middle of the area
    along, in_hand, tracking = [], [], []
    for degrees in (0.0, 15.0, -15.0):
        psi = np.radians(degrees)
        return_home(world)  # each throw from home at rest, as each `throw` command's is
        session.set_target(np.array([x * np.cos(psi), x * np.sin(psi), z]))
        assert session.align().converged
        preview = session.plan_preview()
        execution = session.throw(preview.id).execution
        assert abs(execution.q1 - psi) < 0.005
        # along the throw from the target the throw was planned to (the rig's measurement of it: its
        # few millimetres of noise are the rig's, not the azimuth's)
        along.append(float(execution.landing_link1[0] - preview.target_xz[0]))
        events = world.lab.events
        assert events.release_in_hand is not None and events.released_at is not None
        in_hand.append(events.release_in_hand)
        # the arm's tracking when the ball left: its joints then against the plan's at that time
        throw = preview.throw
        planned, _, _ = throw.trajectory.sample(
            np.array([events.released_at - (execution.t_release - throw.release_time)])
        )
        tracking.append(np.asarray(events.release_q) - planned[0])
    print(
        f"along the throw at 0, +15, -15 deg (mm): {np.round(1e3 * np.array(along), 2)}; ball in the hand at the "
        f"release (mm): {np.round(1e3 * np.array(in_hand), 2).tolist()}; the joints' tracking then (mrad): "
        f"{np.round(1e3 * np.array(tracking), 2).tolist()}"
    )
    # within 5 mm of each other, the bound a lab's procedure is held to (measured 0.4-2.3 mm: the rig's
    # few millimetres on each target's measurement; the lab's own arm spread 64-85 mm)
    assert np.ptp(along) < 0.005
    assert np.ptp(np.array(in_hand), axis=0).max() < 0.0005  # measured 0.03 mm
    # the joints' tracking at the release: 1.9-2.6 mrad on the shoulder at each azimuth, no trend (the
    # three throws' parameters differ a little, their targets measured a few millimetres apart)
    assert np.ptp(np.array(tracking), axis=0).max() < 0.0015


@pytest.mark.parametrize(("lead_s", "largest_m_per_ms"), [(0.0, None), (0.016, 0.0015)])
def test_the_hands_delay_moves_the_landing_unless_the_throw_tells_it_early(lead_s, largest_m_per_ms):
    world = MujocoWorld(lab(lead_s=lead_s), seed=3)
    world.connect()
    arm = world.arm_model
    area = training_area(arm)
    target = np.array([np.mean(area.x), np.mean(area.z)])
    params = solve_throw(arm, target, ball=world.ball())
    landed = []
    for latency_ms in (7.0, 10.0, 13.0):  # the hand's 10 ms, +-1 of its standard deviations
        world.drift(release_latency_s=latency_ms / 1e3)
        return_home(world)
        q = planning_start(world)
        plan = plan_throw(arm, params, float(target[1]), q1=0.0, ball=world.ball(), q_start=q, target=target)
        execution = execute_throw(world, require_valid(plan, arm), measure=False, surface_height=float(target[1]))
        landed.append(execution.landing_link1[0])
    per_ms = np.abs(np.diff(landed)) / 3.0
    print(
        f"lead {1e3 * lead_s:.0f} ms: landings at 7, 10, 13 ms {np.round(landed, 4)} m; {np.round(1e3 * per_ms, 1)} mm per ms"
    )
    if largest_m_per_ms is None:  # told at the release: the ball leaves in the brake
        assert per_ms.min() > 0.004  # measured 6-13 mm per ms of the hand's delay
    else:
        assert per_ms.max() < largest_m_per_ms
