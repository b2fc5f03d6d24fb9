"""The dashboard's parts without a browser: camera pictures, pacing, button rules, the operation
runner, the arm's posing against yourdfpy, the demo command's address and warning."""

from __future__ import annotations

import threading
import time
from dataclasses import replace
from types import SimpleNamespace

import numpy as np
import pytest

from wiithrow.app.session import Busy, Operation, SessionSnapshot
from wiithrow.throwing.landing_error import UNKNOWN, LandingError
from wiithrow.web.camera_views import SLOT_COLORS, CameraViews, render_dots_image
from wiithrow.web.controls import reasons_text
from wiithrow.web.operations import OperationRunner
from wiithrow.web.panels import machine_words, status_text, throws_table
from wiithrow.web.throttle import AdaptiveRate, CostMeter, Every, Ticker


def snapshot(**changes) -> SessionSnapshot:
    return replace(SessionSnapshot(revision=1), **changes)


# -- camera views ------------------------------------------------------------------------------------


def test_dots_are_drawn_in_their_slot_colour_where_the_camera_saw_them():
    dots = np.array([[512.0, 384.0], [np.nan, np.nan], [100.0, 700.0], [np.nan, np.nan]])
    image = render_dots_image(dots, width=256, height=192)
    assert image.shape == (192, 256, 3) and image.dtype == np.uint8
    assert (image[96, 128] == SLOT_COLORS[0]).all()
    assert (image[175, 25] == SLOT_COLORS[2]).all()
    assert not (image == SLOT_COLORS[1]).all(axis=2).any(), "an empty slot draws nothing"


def test_a_silent_camera_is_shown_on_a_red_background():
    fresh = render_dots_image(np.full((4, 2), np.nan), fresh=True)
    stale = render_dots_image(np.full((4, 2), np.nan), fresh=False)
    assert stale[50, 50, 0] > stale[50, 50, 2] and fresh[50, 50, 0] <= fresh[50, 50, 2]


def test_pixel_noise_alone_does_not_resend_a_camera_picture():
    drawn = (True, [(0, 100, 50)])
    assert CameraViews._same(drawn, True, [(0, 101, 49)])
    assert not CameraViews._same(drawn, True, [(0, 103, 50)])
    assert not CameraViews._same(drawn, True, [(0, 100, 50), (1, 10, 10)])
    assert not CameraViews._same(drawn, False, [(0, 100, 50)])


# -- pacing and cost ---------------------------------------------------------------------------------


def test_ticker_keeps_its_rate_and_stops_at_once():
    # 20 ticks at 100 Hz: never sooner than 0.2 s (a late tick is skipped, not made up); a loaded
    # machine may take longer, so the upper bound only says it did not hang
    ticker, stop = Ticker(100.0), threading.Event()
    t0 = time.monotonic()
    ticks = 0
    while ticks < 20 and ticker.wait(stop):
        ticks += 1
    assert ticks == 20 and 0.2 - 0.005 <= time.monotonic() - t0 < 10.0
    stop.set()
    assert not ticker.wait(stop)


def test_every_and_cost_meter():
    every = Every(1.0)
    assert every.due(10.0) and not every.due(10.5) and every.due(11.0)
    meter = CostMeter()
    for _ in range(5):
        with meter.measure():
            sum(range(1000))
    s = meter.summary()
    assert s.updates == 5 and s.wall_p99_ms >= s.wall_p50_ms > 0 and meter.total_cpu_s >= 0


def test_adaptive_rate_stays_within_the_cpu_budget():
    rate = AdaptiveRate(20.0, min_hz=5.0, budget_ms=1.0, tracking_hz=100.0)  # 10 % of a core
    assert rate.observe(cpu_s=0.02 * 20, updates=20) < 20.0  # 20 ms per update: far too dear
    for _ in range(20):
        rate.observe(cpu_s=0.02 * 20, updates=20)
    assert rate.rate_hz == pytest.approx(5.0, abs=0.01)  # 0.1 / 0.02 = 5 Hz, approached by halving the gap
    for _ in range(20):
        rate.observe(cpu_s=0.001 * 20, updates=20)  # 1 ms per update: 100 Hz would fit, capped
    assert rate.rate_hz == pytest.approx(20.0, abs=0.01)


# -- buttons, status, table ----------------------------------------------------------------------------


def replace_ns(ns: SimpleNamespace, **changes) -> SimpleNamespace:
    return SimpleNamespace(**{**vars(ns), **changes})


def test_status_and_table_say_what_happened():
    record = SimpleNamespace(
        index=3,
        wall_time="2026-01-01T12:34:56",
        target_xz=np.array([1.3, 0.2]),
        landing_xz=np.array([1.31, 0.2]),
        error=LandingError(0.006, -0.008, 0.0),  # the 3D error: along, across, height
        true_error=LandingError(0.0, -0.008, 0.0),
        failure=None,
        ball_lost=False,  # not lost in the wind-up
        execution=SimpleNamespace(release_late_s=None),  # released on time
        measured_again=False,
    )
    table = throws_table(snapshot(history=(record,)))
    assert "| 3 | 12:34:56 | 1.300, 0.200 | 1.310, 0.200 | +6.0 / -8.0 / 10.0 | +0.0 / -8.0 / 8.0 |" in table
    failed = replace_ns(record, index=4, landing_xz=np.full(2, np.nan), error=UNKNOWN, true_error=UNKNOWN)
    failed.failure = "the throw failed in the wind-up: stopped by the operator; the arm braked to rest"
    row = throws_table(snapshot(history=(record, failed))).splitlines()[2]
    assert row.startswith("| 4 |") and "**failed** in the wind-up: stopped by the operator" in row and "nan" not in row
    assert throws_table(snapshot()) == "No throws yet."
    # one calibration state: while a calibration runs, its progress, never "not calibrated" beside it
    text = status_text(
        snapshot(operation=Operation.CALIBRATE, progress=("calibrating: pose 3/8", 0.375)), calibrated=False
    )
    assert "Calibration" in text and "calibrating: pose 3/8" in text and "not calibrated" not in text.lower()
    # what runs and on what: "Throw 2 running on ...", never "Throw: ..."
    where = machine_words("MuJoCo (simulated)", "Mitsubishi PA-10 (PA10-7C), 7 joints")
    assert where == "MuJoCo (simulated) Mitsubishi PA-10"
    throwing = snapshot(operation=Operation.THROW, progress=("", 0.0), history=(record,))
    head = status_text(throwing, calibrated=True, where=where).split(" · ")[0]
    assert head == "**Throw 4 running on MuJoCo (simulated) Mitsubishi PA-10: throwing**", head
    homing = snapshot(operation=Operation.HOME, progress=("", 0.0))
    assert status_text(homing, calibrated=True, where=where).startswith(
        "**Home running on MuJoCo (simulated) Mitsubishi PA-10: moving the arm home**"
    )


def test_a_reason_that_holds_back_several_buttons_is_said_once():
    states = {
        Operation.TRACK: "calibrate first",
        Operation.PREVIEW: "calibrate first",
        Operation.THROW: "preview first",
    }
    text = reasons_text(states, (Operation.TRACK, Operation.PREVIEW, Operation.THROW, Operation.HOME))
    assert text == "Not now: *Track target*, *Preview throw*: calibrate first · *Throw*: preview first"
    assert reasons_text({}, (Operation.TRACK,)) == ""


# -- the operation runner ---------------------------------------------------------------------------------


class _FakeSession:
    def __init__(self) -> None:
        self.busy = False
        self.operation = None


def test_one_operation_at_a_time_and_the_second_click_is_told():
    session, told = _FakeSession(), []
    runner = OperationRunner(session, lambda client, title, body, color: told.append((client, title, body)))
    release = threading.Event()
    ran_in = []

    def long_operation():
        ran_in.append(threading.current_thread().name)
        release.wait(5.0)
        return 42

    assert runner.start(Operation.THROW, long_operation, client="A", done=lambda r: ("Done", str(r)))
    assert not runner.start(Operation.THROW, long_operation, client="B")
    assert told[-1][:2] == ("B", "Busy")
    release.set()
    runner.join(5.0)
    assert ran_in == ["wiithrow-web-throw"], "operations run in a worker thread, never the caller's"
    assert told[-1] == (None, "Done", "42")
    assert runner.started == 1 and runner.refused == 1


def test_a_click_after_the_operation_returned_is_not_refused_while_its_worker_still_tells():
    """The worker's tail (its notifications, after the operation returned and the session went idle)
    does not refuse the next operation as Busy: the page shows the button enabled then."""
    session, told = _FakeSession(), []
    telling, release = threading.Event(), threading.Event()

    def notify(client, title, body, color):
        told.append((client, title))
        if title == "Done":
            telling.set()
            release.wait(5.0)  # a slow notification: the worker lives on

    runner = OperationRunner(session, notify)
    assert runner.start(Operation.TRAIN_THROW, lambda: 1, client="A", done=lambda r: ("Done", "thrown"))
    assert telling.wait(5.0) and not runner.running
    assert runner.start(Operation.TRAIN_MEASURE, lambda: 2, client="A"), told
    release.set()
    runner.join(5.0)
    assert ("A", "Busy") not in told and runner.started == 2 and runner.refused == 0


def test_a_refusal_by_the_session_and_a_failure_are_reported():
    session, told = _FakeSession(), []
    runner = OperationRunner(session, lambda client, title, body, color: told.append((client, title, color)))

    def busy():
        raise Busy("calibration is running")

    runner.start(Operation.THROW, busy, client="A")
    runner.join(5.0)
    assert told[-1] == ("A", "Busy", "yellow")

    def fails():
        from wiithrow.app.errors import AppError

        raise AppError("the target is outside the trained area")

    runner.start(Operation.PREVIEW, fails, client="A")
    runner.join(5.0)
    assert told[-1] == (None, "Preview did not complete", "red")


# -- the arm's posing ------------------------------------------------------------------------------------


def test_fast_posing_matches_yourdfpy(tmp_path):
    import viser
    import viser.transforms as vtf

    from wiithrow.robot import load_arm
    from wiithrow.web.arm_view import ArmView

    arm = load_arm("pa10")
    server = viser.ViserServer(port=0, verbose=False)
    try:
        view = ArmView(server, arm.urdf_path, arm.joint_names)
        rng = np.random.default_rng(0)
        for _ in range(3):
            q = rng.uniform(arm.lower, arm.upper)
            view.update(q, force=True)
            view.urdf._urdf.update_cfg(q)
            for joint, frame in zip(view.urdf._joint_map_values, view.urdf._joint_frames):
                T = view.urdf._urdf.get_transform(joint.child, joint.parent)
                expected = vtf.SO3.from_matrix(T[:3, :3]).wxyz
                assert min(np.abs(frame.wxyz - expected).max(), np.abs(frame.wxyz + expected).max()) < 1e-9
                assert np.allclose(frame.position, T[:3, 3])
        assert view.update(q) == 0, "an unchanged pose sends nothing"
    finally:
        server.stop()


# -- the scene's target --------------------------------------------------------------------------------


def test_the_target_and_its_label_are_drawn_only_where_the_target_is(pa10):
    """Issue 21: the target's sphere and label sat at the robot's base during a calibration, in
    serve and in replay (its frame starts at the origin); and the predicted landing's label
    covered the target's."""
    import viser

    from wiithrow.web.scene import SceneView

    server = viser.ViserServer(host="127.0.0.1", port=0, verbose=False)
    try:
        scene = SceneView(server, str(pa10.urdf_path), pa10.joint_names)
        assert not scene.target.visible and not scene._target_label.visible, "hidden until a target exists"
        assert np.isnan(scene.target_shown).all()
        scene.update_target(np.full(3, np.nan))
        assert not scene.target.visible
        where = np.array([1.25, 0.25, 0.2])
        scene.update_target(where)
        assert scene.target.visible and scene._target_label.visible
        assert np.allclose(scene.target.position, where) and np.allclose(scene.target_shown, where)
        scene.update_target(np.full(3, np.nan))  # unlit, as during a calibration
        assert not scene.target.visible and not scene._target_label.visible
        assert np.isnan(scene.target_shown).all(), "an operator's drag handle hides too"
        # the labels of a landing predicted on the target: the target's above, the prediction's below
        target_label, predicted_label = scene._target_label, scene._predicted_label
        assert target_label.position[2] > 0 and predicted_label.position[2] < 0
    finally:
        server.stop()
