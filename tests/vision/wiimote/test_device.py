"""The real driver against the simulated remote: start sequence, dots against the truth, faults."""

from __future__ import annotations

import time

import numpy as np
import pytest

from wiithrow.clock import SimClock, SystemClock
from wiithrow.vision.camera import WiimoteCamera
from wiithrow.vision.wiimote import protocol
from wiithrow.vision.wiimote.device import WiimoteDriver
from wiithrow.vision.wiimote.driver_settings import DriverSettings, DriverState, WiimoteError
from wiithrow.vision.wiimote.sim_faults import SimFaults
from wiithrow.vision.wiimote.simulator import SimulatedWiimote
from wiithrow.vision.wiimote.transport import DeviceAccessError

CAM = WiimoteCamera.at([0.0, 0.0, 0.0], [1.0, 0.0, 0.0], name="cam0")
STATIC = np.array([[1.0, 0.10, 0.05], [1.5, -0.20, 0.10], [2.0, 0.30, -0.20]])
T0 = 100.0


def moving(t):
    """Three sources sweeping across the view (each report sees new pixels)."""
    s = t - T0
    return np.array(
        [[1.2, 0.3 - 0.2 * s, 0.05], [1.6, -0.25 + 0.1 * s, 0.1 * np.sin(3 * s)], [2.0, 0.0, -0.2 + 0.1 * s]]
    )


def rig(sources=STATIC, *, seed=0, faults=None, sim_kw=None, on_state=None, **settings):
    clock = SimClock(T0)
    src = sources if callable(sources) else (lambda t: sources)
    sim = SimulatedWiimote(CAM, src, clock, np.random.default_rng(seed), sigma_px=0.0, faults=faults, **(sim_kw or {}))
    drv = WiimoteDriver(sim, clock, DriverSettings(**settings), on_state=on_state)
    return sim, drv, clock


def run(drv, clock, seconds, step=0.01):
    frames = []
    for _ in range(round(seconds / step)):
        clock.advance(step)
        frames += drv.poll()
    return frames


def truth_pixels(points):
    return {tuple(p) for p in np.rint(CAM.project(points)).astype(int)}


def frame_pixels(frame):
    return {tuple(int(v) for v in d) for d in frame.dots[frame.visible]}


def sent_reports(sim):
    return [h for h in sim.history if not h.dropped]


# ---------------------------------------------------------------- start sequence and dots


@pytest.mark.parametrize("sensitivity", list(protocol.SENSITIVITY_BLOCKS))
@pytest.mark.parametrize("ir_format", ["basic", "extended", "full"])
def test_every_format_and_sensitivity_streams_exact_dots(ir_format, sensitivity):
    sim, drv, clock = rig(sensitivity=sensitivity, ir_format=ir_format)
    drv.connect()
    assert drv.state is DriverState.STREAMING
    frames = run(drv, clock, 0.3)
    fmt = protocol.IRFormat.from_name(ir_format)

    # the remote holds exactly the configuration the driver meant
    b1, b2 = protocol.SENSITIVITY_BLOCKS[sensitivity]
    assert sim.register(0xB00000, 9) == b1 and sim.register(0xB0001A, 2) == b2
    assert sim.sensitivity == sensitivity
    assert sim.register(0xB00033) == bytes([fmt.value]) and sim.register(0xB00030) == b"\x08"
    assert sim.report_mode == drv.settings.report_mode and sim.continuous
    assert sim.leds == 0x10 and not sim.rumble

    # the kernel's order, writes exactly as long as their reports, rumble never on
    w = sim.writes_log
    assert [x[0] for x in w] == [0x11, 0x15, 0x13, 0x1A] + [0x16] * 5 + [0x12]
    assert [x[2:5].hex() for x in w[4:9]] == ["b00030", "b00000", "b0001a", "b00033", "b00030"]
    assert all(len(x) == protocol.OUTPUT_LENGTHS[x[0]] for x in w)
    assert all(x[1] & protocol.FLAG_RUMBLE == 0 for x in w)

    expected_frames = 31 if fmt is not protocol.IRFormat.FULL else 15  # reports k = 0..30; full pairs them
    assert len(frames) == expected_frames
    truth = truth_pixels(STATIC)
    sizes = dict(zip(map(tuple, np.rint(CAM.project(STATIC)).astype(int)), CAM.blob_sizes(STATIC)))
    for f in frames:
        assert frame_pixels(f) == truth
        assert f.dots.shape == (4, 2) and f.sizes.shape == (4,)
        assert np.isnan(f.dots[3]).all()  # three sources, slot 3 empty
        if fmt is protocol.IRFormat.BASIC:
            assert np.isnan(f.sizes).all()
        else:
            assert all(f.sizes[s] == sizes[tuple(f.dots[s].astype(int))] for s in range(3))
        if fmt is protocol.IRFormat.FULL:
            assert np.isfinite(f.bboxes[:3]).all() and np.isnan(f.bboxes[3]).all()
            assert np.isfinite(f.intensities[:3]).all()
            assert f.accel == (512, 512, 616)
    assert [f.seq for f in frames] == list(range(len(frames)))
    assert drv.stats.bad_reports == 0 and drv.stats.drops_detected == 0
    assert drv.stats.frames == len(frames)


@pytest.mark.parametrize("ir_format", ["basic", "extended"])
def test_moving_sources_every_frame_matches_what_was_sent(ir_format):
    sim, drv, clock = rig(moving, ir_format=ir_format)
    drv.connect()
    frames = drv.poll() + run(drv, clock, 1.0)
    sent = sent_reports(sim)
    assert len(frames) == len(sent) == 101
    for f, h in zip(frames, sent):
        expected = {(x, y) for _, x, y in h.slots.values()}
        assert frame_pixels(f) == expected
        assert expected == truth_pixels(moving(h.t)) & expected  # the sim's truth is the camera model's
        assert f.t_device == pytest.approx(h.t, abs=1e-9)  # read every 10 ms: exact send times
        for slot, (_, x, y) in h.slots.items():
            assert tuple(f.dots[slot]) == (x, y)


def test_full_format_frames_pair_halves_of_the_same_camera_frame():
    sim, drv, clock = rig(moving, ir_format="full", faults=SimFaults(drop_probability=0.2), seed=4)
    drv.connect()
    frames = drv.poll() + run(drv, clock, 2.0)
    hist = list(sim.history)
    pairs = {}
    for a, b in zip(hist[::2], hist[1::2]):
        pairs[a.k] = {**{s: v[1:] for s, v in a.slots.items()}, **{s: v[1:] for s, v in b.slots.items()}}
    valid = [{s: tuple(int(v) for v in f.dots[s]) for s in range(4) if f.visible[s]} for f in frames]
    assert all(v in pairs.values() for v in valid)  # never a 0x3E of one frame with the 0x3F of another
    complete = sum(1 for a, b in zip(hist[::2], hist[1::2]) if not a.dropped and not b.dropped)
    assert len(frames) == complete
    assert drv.stats.incomplete_pairs >= 1


@pytest.mark.parametrize("player, bits", [(1, 0x10), (2, 0x20), (3, 0x40), (4, 0x80)])
def test_player_leds(player, bits):
    sim, drv, _clock = rig(player_led=player)
    drv.connect()
    assert sim.leds == bits


def test_driver_reads_registers_back():
    _sim, drv, clock = rig(sensitivity="marcan")
    drv.connect()
    assert drv.read_registers(0xB00000, 9) == protocol.SENSITIVITY_BLOCKS["marcan"][0]
    assert drv.read_registers(0xB00000, 0x34)[0x33] == 3
    frames = run(drv, clock, 0.1)  # reports that came in while reading are not lost
    assert len(frames) >= 10


def test_bad_settings_are_refused_up_front():
    with pytest.raises(protocol.ProtocolError, match="level9"):
        DriverSettings(sensitivity="level9")
    with pytest.raises(protocol.ProtocolError, match="basic, extended, full"):
        DriverSettings(ir_format="raw")
    with pytest.raises(protocol.ProtocolError):
        DriverSettings(player_led=5)
    with pytest.raises(protocol.ProtocolError, match="0x36 or 0x37"):
        DriverSettings(ir_format="basic", basic_report_mode=0x33)


# ---------------------------------------------------------------- faults


def test_dead_camera_is_restarted():
    sim, drv, clock = rig(faults=SimFaults(dead_starts=1))
    t = clock.now()
    drv.connect()
    assert drv.state is DriverState.STREAMING
    assert drv.stats.camera_restarts == 1 and drv.stats.camera_starts == 2
    assert sim.stats.starts_ignored == 1
    assert 0.5 <= clock.now() - t < 0.6  # it waited stream_timeout_s = 0.5 s for the first try
    frames = run(drv, clock, 0.2)
    assert len(frames) == 21 and all(frame_pixels(f) == truth_pixels(STATIC) for f in frames)  # k = 0..20


def test_camera_that_never_comes_up_gives_a_clear_error():
    sim, drv, _clock = rig(faults=SimFaults(dead_starts=10), start_attempts=3)
    with pytest.raises(WiimoteError, match="did not start streaming after 3 start sequences"):
        drv.connect()
    assert drv.state is DriverState.CLOSED and not sim.is_open


def test_stalled_camera_mid_stream_is_restarted():
    sim, drv, clock = rig(faults=SimFaults(stall_at=T0 + 1.0))
    drv.connect()
    run(drv, clock, 2.0)
    assert drv.stats.camera_restarts == 1
    assert drv.state is DriverState.STREAMING and sim.streaming
    frames = run(drv, clock, 0.1)
    assert len(frames) == 10


@pytest.mark.parametrize("step", [0.01, 0.03])
def test_dropped_reports_are_counted_and_the_stream_continues(step):
    sim, drv, clock = rig(moving, faults=SimFaults(drop_probability=0.1), seed=11)
    drv.connect()
    frames = drv.poll() + run(drv, clock, 10.0, step=step)
    delivered = sent_reports(sim)
    assert len(frames) == len(delivered) == sim.stats.data_reports
    assert 50 < sim.stats.dropped < 150
    if step == 0.01:
        assert drv.stats.drops_detected == sim.stats.dropped  # read every 10 ms: exact
    else:
        assert abs(drv.stats.drops_detected - sim.stats.dropped) <= 1  # batched: within one report
    for f, h in zip(frames, delivered):
        assert frame_pixels(f) == {(x, y) for _, x, y in h.slots.values()}


def test_zero_zero_dots_become_nan():
    def sources(t):  # a second source appears after 0.1 s
        s = t - T0
        pts = [[1.0, 0.1, 0.0]]
        if s >= 0.1:
            pts.append([1.5, -0.2, 0.1])
        return np.array(pts)

    sim, drv, clock = rig(sources, faults=SimFaults(zero_missing=True, zero_first=True))
    drv.connect()
    frames = drv.poll() + run(drv, clock, 0.3)
    assert all(not np.any((f.dots == 0).all(axis=1)) for f in frames)
    assert np.isnan(frames[0].dots).all()  # first report of the first blob: (0, 0)
    assert frames[1].visible.tolist() == [True, False, False, False]
    appear = next(i for i, h in enumerate(sent_reports(sim)) if len(sources(h.t)) == 2)
    assert frames[appear].visible.tolist() == [True, False, False, False]  # (0, 0) on its first report
    assert frames[appear + 1].visible.tolist() == [True, True, False, False]
    assert np.isnan(frames[-1].dots[2:]).all()


def test_disconnect_and_reconnect_recover_the_stream():
    states = []
    sim, drv, clock = rig(
        moving,
        faults=SimFaults(disconnect_at=T0 + 0.5, reconnect_after=1.0),
        on_state=lambda s, msg: states.append((round(clock.now() - T0, 3), s)),
    )
    drv.connect()
    frames = drv.poll() + run(drv, clock, 3.0)
    assert [s for _, s in states] == [
        DriverState.CONNECTING,
        DriverState.STREAMING,
        DriverState.DISCONNECTED,
        DriverState.STREAMING,
    ]
    t_lost, t_back = states[2][0], states[3][0]
    assert t_lost == pytest.approx(0.51, abs=0.011)
    assert 1.5 <= t_back <= 1.5 + 1.0  # back after 1 s, found within one back-off interval
    assert drv.stats.disconnects == 1 and drv.stats.reconnects == 1 and drv.stats.reconnect_failures >= 1
    gap = np.diff([f.t for f in frames]).max()
    assert gap >= 1.0
    late = [f for f in frames if f.t - T0 > t_back]
    assert len(late) >= 50
    for f in late:  # dots resume, correct
        assert frame_pixels(f) <= truth_pixels(moving(f.t_device))
        assert len(frame_pixels(f)) == 3
    assert sim.leds == 0x10 and sim.sensitivity == "level3"  # the power-cycled remote was set up again


def test_reconnect_back_off_doubles_up_to_the_maximum():
    attempts = []

    class Recording(SimulatedWiimote):
        def open(self):
            attempts.append(self.clock.now())
            return super().open()

    clock = SimClock(T0)
    sim = Recording(
        CAM,
        lambda t: STATIC,
        clock,
        np.random.default_rng(0),
        sigma_px=0.0,
        faults=SimFaults(disconnect_at=T0 + 0.2, reconnect_after=None),
    )
    drv = WiimoteDriver(sim, clock, DriverSettings(backoff_initial_s=0.1, backoff_max_s=2.0))
    drv.connect()
    run(drv, clock, 20.0, step=0.01)
    intervals = np.diff(attempts[1:])  # attempts[0] is the first connect
    assert drv.state is DriverState.DISCONNECTED
    assert np.allclose(intervals[:4], [0.2, 0.4, 0.8, 1.6], atol=0.011)
    assert np.allclose(intervals[4:], 2.0, atol=0.011) and len(intervals) >= 8


def test_garbage_is_counted_and_skipped():
    sim, drv, clock = rig(moving, faults=SimFaults(garbage_probability=0.3), seed=9)
    drv.connect()
    frames = drv.poll() + run(drv, clock, 3.0)
    assert drv.stats.bad_reports == sim.stats.garbage > 50
    delivered = sent_reports(sim)
    assert len(frames) == len(delivered)
    for f, h in zip(frames, delivered):
        assert frame_pixels(f) == {(x, y) for _, x, y in h.slots.values()}


def test_lost_acks_are_retried():
    _sim, drv, clock = rig(faults=SimFaults(lost_acks=2))
    drv.connect()
    assert drv.stats.write_retries == 2
    assert len(run(drv, clock, 0.1)) == 11  # k = 0 (read while connecting) .. 10


def test_remote_that_never_acks_gives_a_clear_error():
    _sim, drv, _clock = rig(faults=SimFaults(lost_acks=100), write_retries=3)
    with pytest.raises(WiimoteError, match=r"IR pixel clock \(0x13\) after 3 tries.*hid-wiimote"):
        drv.connect()


def test_unsolicited_status_makes_the_driver_resend_the_mode():
    sim, drv, clock = rig()
    drv.connect()
    run(drv, clock, 0.1)
    sim.send_unsolicited_status()
    frames = run(drv, clock, 0.2)
    assert len(frames) >= 19
    assert [w[0] for w in sim.writes_log].count(0x12) == 2
    assert drv.stats.camera_restarts == 0


def test_factory_is_called_again_on_reconnect():
    clock = SimClock(T0)
    made = []

    def factory():
        sim = SimulatedWiimote(
            CAM,
            lambda t: STATIC,
            clock,
            np.random.default_rng(len(made)),
            sigma_px=0.0,
            faults=SimFaults(disconnect_at=T0 + 0.3, reconnect_after=0.0) if not made else None,
        )
        made.append(sim)
        return sim

    drv = WiimoteDriver(factory, clock)
    drv.connect()
    run(drv, clock, 1.0)
    assert len(made) == 2 and drv.stats.reconnects == 1 and drv.state is DriverState.STREAMING


def test_access_denied_propagates_from_connect():
    def factory():
        raise DeviceAccessError("permission denied: udev rule needed")

    drv = WiimoteDriver(factory, SimClock())
    with pytest.raises(DeviceAccessError, match="udev"):
        drv.connect()
    assert drv.state is DriverState.CLOSED


def test_missing_device_is_a_clear_error():
    clock = SimClock()
    sim = SimulatedWiimote(
        CAM,
        lambda t: STATIC,
        clock,
        np.random.default_rng(0),
        faults=SimFaults(disconnect_at=0.0, reconnect_after=None),
    )
    with pytest.raises(WiimoteError, match="cannot talk to the remote"):
        WiimoteDriver(sim, clock).connect()


def test_close_switches_the_camera_off():
    sim, drv, _clock = rig()
    drv.connect()
    drv.close()
    assert not sim.is_open and not sim.pixel_clock and not sim.ir_logic
    assert drv.state is DriverState.CLOSED


# ---------------------------------------------------------------- the background thread


def test_thread_delivers_frames_in_real_time_and_survives_a_disconnect():
    clock = SystemClock()
    sim = SimulatedWiimote(CAM, lambda t: STATIC, clock, np.random.default_rng(0), sigma_px=0.0, realtime=True)
    drv = WiimoteDriver(sim, clock, DriverSettings(backoff_initial_s=0.05))
    drv.start()
    try:
        with pytest.raises(RuntimeError, match="background"):
            drv.poll()
        time.sleep(0.3)
        sim.disconnect(duration=0.2)
        time.sleep(0.6)
    finally:
        drv.stop()
    frames = []
    while not drv.frames.empty():
        frames.append(drv.frames.get_nowait())
    assert drv.stats.disconnects == 1 and drv.stats.reconnects == 1
    assert drv.state is DriverState.STREAMING
    assert 30 <= len(frames) <= 100  # ~0.3 s + ~0.4 s of 100 Hz, minus the outage
    assert all(frame_pixels(f) == truth_pixels(STATIC) for f in frames)
    assert drv.stats.loop_errors == 0
    drv.close()


def test_thread_with_callback_and_a_failing_callback():
    clock = SystemClock()
    sim = SimulatedWiimote(CAM, lambda t: STATIC, clock, np.random.default_rng(0), sigma_px=0.0, realtime=True)
    got = []

    def on_frame(f):
        got.append(f)
        if len(got) % 5 == 0:
            raise ValueError("a buggy consumer")

    drv = WiimoteDriver(sim, clock)
    drv.start(on_frame)
    deadline = time.monotonic() + 30.0  # 15 frames take 0.15 s of a 100 Hz remote; a loaded machine, longer
    while len(got) < 15 and time.monotonic() < deadline:
        time.sleep(0.01)
    drv.close()
    assert len(got) >= 15 and drv.stats.callback_errors == len(got) // 5
    assert drv.state is DriverState.CLOSED and drv.frames.empty()
