"""A world whose markers cross Zenoh (`wiithrow.app.worlds.remote`): in the simulated world the
rig's frames are published on one Zenoh session and read back on another (connected over
loopback TCP), and the session aligns and throws on them; the latency of that path is measured."""

import numpy as np
import pytest

from wiithrow.app.cli.bench.publish import free_port, loopback_configs
from wiithrow.app.errors import AppError
from wiithrow.app.network.remote_rig import RemoteRig
from wiithrow.app.network.zenoh_session import open_session
from wiithrow.app.rig.waiting import pump
from wiithrow.app.session import Operation, Session, demo_target_base
from wiithrow.app.worlds import SimWorld
from wiithrow.app.worlds.remote import simulated_loopback


@pytest.fixture
def loopback(tmp_path):
    listen_cfg, connect_cfg = loopback_configs(tmp_path, free_port())
    subscriber = open_session(listen_cfg)
    publisher = open_session(connect_cfg)
    yield publisher, subscriber
    publisher.close()
    subscriber.close()


def test_alignment_and_a_throw_on_markers_that_crossed_zenoh(loopback):
    publish, subscribe = loopback
    # the world is built with its marker source: its own rig tracked with the true calibration,
    # published on one Zenoh session and read back on the other
    world = SimWorld(seed=0, markers=simulated_loopback(publish, subscribe, "lab"))
    session = Session(world, rng=np.random.default_rng(1))
    try:
        rig = world.rig
        assert isinstance(rig, RemoteRig) and rig.calibration_revision == 1
        world.connect()
        pump(world.clock, rig, 0.2, step_s=0.001)  # the tracker confirms what the rig sees
        # one precondition for the buttons and the server: Track works on markers tracked far away,
        # a calibration here is refused before anything moves
        assert session.refusal(Operation.TRACK) is None
        for op in (Operation.CALIBRATE, Operation.CALIBRATE_WAND, Operation.LOAD_CALIBRATION):
            assert "calibrate the rig on the host that tracks it" in session.refusal(op)
        session.set_target(demo_target_base())
        alignment = session.align()
        assert alignment.converged
        record = session.throw(session.plan_preview().id)
        with pytest.raises(AppError, match="calibrate the rig on the host that tracks it"):
            session.world.set_calibration(session.world.true_calibration())
        # refused before the arm moves through its poses (it used to move, then refuse the result)
        q_before = session.world.arm.state().q.copy()
        for calibrate in (lambda: session.calibrate(8), lambda: session.calibrate_wand(5.0)):
            with pytest.raises(AppError, match="calibrate the rig on the host that tracks it"):
                calibrate()
        assert np.allclose(session.world.arm.state().q, q_before) and not session.busy
    finally:
        session.close()
    assert rig.received > 100 and len(rig.tracked) > 100
    assert rig.received == rig._expected  # every published frame came back
    assert all(
        frame is not None and frame.visible.any() for frame in rig.latest
    )  # each camera's dots, for the dashboard
    # The throw lands on the target as on a local rig (test_session's bound for the kinematic world).
    assert record.error_m < 0.01 and record.true_error_m < 0.01 and np.isfinite(record.landing_xz).all()
    latency = rig.latency_ms()
    assert 0 < latency["p50_ms"] <= latency["p99_ms"] < 100.0


def test_frames_read_together_keep_their_spacing_on_this_clock(loopback):
    from wiithrow.app.channels.zenoh_sink import RigPublisher
    from wiithrow.app.settings import Settings
    from wiithrow.app.worlds import nominal_cameras
    from wiithrow.clock import SimClock
    from wiithrow.vision.tracked_frame import TrackedFrame

    publish, subscribe = loopback
    clock = SimClock()
    clock.sleep(5.0)
    Ps = np.stack([c.P for c in nominal_cameras(Settings().rig)])
    rig = RemoteRig(subscribe, "wiithrow/lab", ["cam0", "cam1"], Ps, clock, settle_s=5.0)
    publisher = RigPublisher(publish, "lab", ["cam0", "cam1"], "link1")
    assert publisher.wait_for_subscribers(10.0)
    rig.pin.named_source = str(publish.zid())  # as `serve --markers-source` names it
    empty = np.zeros((0, 3))
    for t in (100.00, 100.01, 100.02):  # the far host's clock
        publisher.publish_markers(
            TrackedFrame(t, np.zeros(0, np.int64), empty, empty, empty, np.zeros(0, bool), np.zeros(0, np.int64))
        )
    rig._expected = 3  # wait for all three (as simulated_loopback's source says)
    rig.poll()
    frames = rig.tracked_since(-np.inf)
    rig.close()
    assert [f.t for f in frames] == pytest.approx([4.98, 4.99, 5.00])


def test_a_frame_that_never_comes_back_costs_one_settle_wait_not_one_per_poll(loopback):
    """The source says it published two frames, one arrives: that poll waits `settle_s` for the
    other, and gives up on it; the polls after it wait for nothing (before, each waited
    `settle_s` again for the same missing frame: 289 s of one test under load)."""
    import time

    from wiithrow.app.channels.zenoh_sink import RigPublisher
    from wiithrow.app.settings import Settings
    from wiithrow.app.worlds import nominal_cameras
    from wiithrow.clock import SimClock
    from wiithrow.vision.tracked_frame import TrackedFrame

    publish, subscribe = loopback
    clock = SimClock()
    Ps = np.stack([c.P for c in nominal_cameras(Settings().rig)])
    settle_s = 0.5
    rig = RemoteRig(subscribe, "wiithrow/lab", ["cam0", "cam1"], Ps, clock, settle_s=settle_s)
    publisher = RigPublisher(publish, "lab", ["cam0", "cam1"], "link1")
    try:
        assert publisher.wait_for_subscribers(10.0)
        empty = np.zeros((0, 3))
        rig.pin.named_source = str(publish.zid())  # what simulated_loopback names
        publisher.publish_markers(
            TrackedFrame(1.0, np.zeros(0, np.int64), empty, empty, empty, np.zeros(0, bool), np.zeros(0, np.int64))
        )
        rig._expected = 2  # one more than was published: lost on the way
        start = time.monotonic()
        rig.poll()
        first = time.monotonic() - start
        assert first >= settle_s  # waited for the missing one, up to settle_s
        assert rig._from_source == 1 and rig._expected == 1  # and gave up on it
        start = time.monotonic()
        for _ in range(5):
            rig.poll()
        assert time.monotonic() - start < 5 * settle_s / 2  # not 5 x settle_s: nothing is awaited
    finally:
        rig.close()
