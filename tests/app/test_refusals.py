"""Each operation's precondition, written once (`wiithrow.app.session.refusals.refusal`): for every
operation, in the states that refuse it and the state that lets it start, on the kinematic world
(uncalibrated and tracking), a world whose arm has no driver and a world without a hand; and the
session raising that very text as the operation begins, before anything moves."""

from __future__ import annotations

from dataclasses import replace
from types import SimpleNamespace

import numpy as np
import pytest

from wiithrow.app.errors import AppError
from wiithrow.app.session import (
    NO_ARM,
    TARGET_MOVED_M,
    Busy,
    Operation,
    Session,
    SessionSnapshot,
    refusal,
    simulated_session,
)
from wiithrow.app.session.refusals import (
    CALIBRATE_FIRST,
    NOTHING_LANDED,
    PREVIEW_FIRST,
    REAL_TARGET,
    THROW_FIRST,
    TRACK_FIRST,
)
from wiithrow.app.session.refusals import TARGET_MOVED as MOVED
from wiithrow.app.worlds import SimWorld
from wiithrow.app.worlds.base import NO_GRIPPER
from wiithrow.app.worlds.hardware import HardwareWorld
from wiithrow.robot import SimulatedArm

IDLE = SessionSnapshot()
#: An alignment as the session keeps it (only `converged` is read by the rules).
ALIGNED = SimpleNamespace(converged=True)
NOT_ALIGNED = SimpleNamespace(converged=False)
THROWN = (SimpleNamespace(index=1, failure=None, execution=SimpleNamespace(t_release=1.55)),)
PREVIEWED = SimpleNamespace(id=1)


def why(op: Operation, state: SessionSnapshot, world) -> str | None:
    found = refusal(op, state, world)
    return None if found is None else found.reason


@pytest.fixture(scope="module")
def tracking():
    """A kinematic world whose rig tracks (the true calibration)."""
    world = SimWorld(seed=2)
    world.set_calibration(world.true_calibration())
    return world


@pytest.fixture(scope="module")
def parked():
    """Real-hardware shape: no arm driver (a parked arm), no gripper, remotes that are never opened."""
    from tests.app.test_hardware_world import remote_drivers

    return HardwareWorld(drivers=remote_drivers())


@pytest.fixture(scope="module")
def handless():
    """An arm with a driver but no hand."""
    from tests.app.test_hardware_world import remote_drivers, true_calibration
    from wiithrow.app.settings import Settings

    settings = Settings().replace(arm_driver="tests.app.test_hardware_world:make_arm")
    world = HardwareWorld(settings, drivers=remote_drivers(), calibration=true_calibration())
    assert isinstance(world.arm, SimulatedArm) and world.gripper is None
    return world


def test_stop_is_never_refused(sim_world, parked):
    for world in (sim_world, parked):
        for state in (IDLE, replace(IDLE, operation=Operation.THROW)):
            assert why(Operation.STOP, state, world) is None


def test_while_one_operation_runs_every_other_is_busy_but_the_target_may_move_while_tracking(sim_world):
    for running in Operation:
        state = replace(IDLE, operation=running)
        for op in Operation:
            if op is Operation.STOP:
                continue
            found = refusal(op, state, sim_world)
            if op is Operation.MOVE_TARGET and running is Operation.TRACK:
                assert found is None, "the target may move while it is tracked"
                continue
            assert found is not None and found.busy, (op, running)
            assert found.reason.startswith(f"busy: {running.doing}"), found.reason
            assert isinstance(found.error(), Busy)


def test_an_uncalibrated_world_calibrates_first(sim_world):
    assert why(Operation.CALIBRATE, IDLE, sim_world) is None
    assert why(Operation.CALIBRATE_WAND, IDLE, sim_world) is None
    assert why(Operation.LOAD_CALIBRATION, IDLE, sim_world) is None
    assert why(Operation.HOME, IDLE, sim_world) is None
    assert why(Operation.TRACK, IDLE, sim_world) == CALIBRATE_FIRST
    assert why(Operation.PREVIEW, IDLE, sim_world) == CALIBRATE_FIRST
    assert why(Operation.THROW, IDLE, sim_world) == PREVIEW_FIRST
    assert why(Operation.MEASURE_LANDING, IDLE, sim_world) == THROW_FIRST
    assert why(Operation.MEASURE_LANDING, replace(IDLE, history=THROWN), sim_world) == CALIBRATE_FIRST
    assert why(Operation.MOVE_TARGET, IDLE, sim_world) is None
    assert why(Operation.CHANGE_PLANNER, IDLE, sim_world) is None


def test_a_tracking_world_goes_track_preview_throw_measure(tracking):
    assert why(Operation.TRACK, IDLE, tracking) is None
    assert why(Operation.PREVIEW, IDLE, tracking) == TRACK_FIRST
    assert why(Operation.PREVIEW, replace(IDLE, alignment=NOT_ALIGNED), tracking) == TRACK_FIRST
    aligned = replace(IDLE, alignment=ALIGNED)
    assert why(Operation.PREVIEW, aligned, tracking) is None
    assert why(Operation.THROW, aligned, tracking) == PREVIEW_FIRST
    assert why(Operation.THROW, replace(aligned, preview=PREVIEWED), tracking) is None
    assert why(Operation.MEASURE_LANDING, replace(aligned, history=THROWN), tracking) is None


def test_a_throw_that_failed_before_the_release_has_no_landing_to_measure(tracking):
    """A failed throw's record has nothing measured; one whose hand never opened has nothing landed."""
    kept = SimpleNamespace(
        index=2, failure="the throw failed in the wind-up: ...", execution=SimpleNamespace(t_release=np.nan)
    )
    flown = SimpleNamespace(
        index=2, failure="the throw failed in flight: ...", execution=SimpleNamespace(t_release=1.55)
    )
    assert why(Operation.MEASURE_LANDING, replace(IDLE, history=(*THROWN, kept)), tracking) == NOTHING_LANDED
    assert why(Operation.MEASURE_LANDING, replace(IDLE, history=(*THROWN, flown)), tracking) is None


def test_a_target_moved_since_the_alignment_asks_to_track_again(tracking):
    placed = np.array([1.3, 0.2, 0.2])
    aligned = replace(IDLE, alignment=ALIGNED, target_base=placed, aligned_target_base=placed)
    nudged = replace(aligned, target_base=placed + [0.0, 0.5 * TARGET_MOVED_M, 0.0])
    moved = replace(aligned, target_base=placed + [0.0, 1.5 * TARGET_MOVED_M, 0.0])
    assert why(Operation.PREVIEW, nudged, tracking) is None, "within TARGET_MOVED_M the alignment holds"
    assert why(Operation.PREVIEW, moved, tracking) == MOVED
    unknown = replace(aligned, target_base=np.full(3, np.nan))  # a real target: nothing placed from here
    assert why(Operation.PREVIEW, unknown, tracking) is None


def test_an_arm_without_a_driver_refuses_what_needs_it_and_still_calibrates_with_a_wand(parked):
    for op in (
        Operation.CALIBRATE,
        Operation.HOME,
        Operation.TRACK,
        Operation.PREVIEW,
        Operation.THROW,
        Operation.MEASURE_LANDING,
    ):
        assert why(op, replace(IDLE, alignment=ALIGNED, preview=PREVIEWED, history=THROWN), parked) == NO_ARM, op
    assert why(Operation.CALIBRATE_WAND, IDLE, parked) is None
    assert why(Operation.LOAD_CALIBRATION, IDLE, parked) is None
    assert why(Operation.MOVE_TARGET, IDLE, parked) == REAL_TARGET


def test_a_world_without_a_hand_refuses_the_throw_whatever_was_previewed(handless):
    assert why(Operation.THROW, replace(IDLE, preview=PREVIEWED), handless) == NO_GRIPPER
    assert why(Operation.THROW, IDLE, handless) == NO_GRIPPER
    assert why(Operation.TRACK, IDLE, handless) is None


def test_the_session_raises_the_same_text_before_anything_moves():
    session = simulated_session(seed=7, calibration=None, quiet=True)
    try:
        q0 = session.world.arm.state().q.copy()
        for op, call in (
            (Operation.TRACK, session.align),
            (Operation.PREVIEW, session.plan_preview),
            (Operation.MEASURE_LANDING, session.measure_landing),
        ):
            text = session.refusal(op)
            assert text, op
            with pytest.raises(AppError) as raised:
                call()
            assert str(raised.value) == text
        assert session.refusal(Operation.THROW) == PREVIEW_FIRST
        with pytest.raises(AppError, match="no longer current"):  # a named preview that is not there
            session.throw(1)
        assert np.array_equal(session.world.arm.state().q, q0) and not session.busy
        assert session.refusal(Operation.CALIBRATE) is None and session.refusal(Operation.STOP) is None
    finally:
        session.close()


def test_a_session_on_a_parked_arm_says_so_for_every_arm_operation(parked):
    session = Session(parked)
    refusals = session.refusals()
    assert refusals[Operation.STOP] is None
    assert all(refusals[op] == NO_ARM for op in (Operation.HOME, Operation.TRACK, Operation.CALIBRATE))
    with pytest.raises(AppError, match="no arm driver"):
        session.home()
