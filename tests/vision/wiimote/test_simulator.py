"""The simulated Wiimote at the byte level, driven by hand-written output reports (no driver)."""

from __future__ import annotations

import dataclasses
import time

import numpy as np
import pytest

from wiithrow.clock import SimClock, SystemClock
from wiithrow.vision.camera import WiimoteCamera
from wiithrow.vision.wiimote import input_reports, output_reports, protocol
from wiithrow.vision.wiimote.sim_faults import SentReport, SimFaults
from wiithrow.vision.wiimote.simulator import HID_BUFFER_SIZE, SimulatedWiimote

H = bytes.fromhex
CAM = WiimoteCamera.at([0.0, 0.0, 0.0], [1.0, 0.0, 0.0], name="cam0")
STATIC = np.array([[1.0, 0.10, 0.05], [1.5, -0.20, 0.10], [2.0, 0.30, -0.20]])


def make(sources=STATIC, *, seed=0, **kw):
    clock = SimClock(10.0)
    src = sources if callable(sources) else (lambda t: sources)
    sim = SimulatedWiimote(CAM, src, clock, np.random.default_rng(seed), **{"sigma_px": 0.0, **kw})
    sim.open()
    return sim, clock


def drain(sim):
    out = []
    while True:
        r = sim.read(22, 0)
        if not r:
            return out
        out.append(r)


def start(sim, *, sensitivity="level3", mode_byte=3, report_mode=0x33, skip=()):
    """The kernel's start sequence by hand; `skip` leaves out steps by index."""
    b1, b2 = protocol.SENSITIVITY_BLOCKS[sensitivity]
    steps = [
        H("13 06"),
        H("1A 06"),
        output_reports.encode_write(0xB00030, b"\x01"),
        output_reports.encode_write(0xB00000, b1),
        output_reports.encode_write(0xB0001A, b2),
        output_reports.encode_write(0xB00033, bytes([mode_byte])),
        output_reports.encode_write(0xB00030, b"\x08"),
        bytes([0x12, 0x04, report_mode]),
    ]
    for i, s in enumerate(steps):
        if i not in skip:
            assert sim.write(s) == len(s)
    return [input_reports.parse(r) for r in drain(sim)]


def ir_reports(sim):
    return [r for r in (input_reports.parse(b) for b in drain(sim)) if isinstance(r, input_reports.IRReport)]


# ---------------------------------------------------------------- refusing to stream


def test_nothing_streams_before_a_complete_start_sequence():
    sim, clock = make()
    clock.advance(1.0)
    assert drain(sim) == []
    sim.write(H("12 04 33"))  # a reporting mode alone does nothing
    clock.advance(0.5)
    assert ir_reports(sim) == []


@pytest.mark.parametrize("skipped", range(8))
def test_any_missing_step_keeps_the_camera_silent(skipped):
    sim, clock = make()
    start(sim, skip={skipped})
    clock.advance(0.5)
    assert ir_reports(sim) == []
    assert not sim.streaming


def test_complete_sequence_streams_and_acks_every_write():
    sim, clock = make()
    replies = start(sim)
    acks = [r for r in replies if isinstance(r, input_reports.Ack)]
    assert [(a.acked_report, a.error) for a in acks] == [(0x13, 0), (0x1A, 0)] + [(0x16, 0)] * 5
    assert sim.streaming and sim.camera_running and sim.sensitivity == "level3"
    clock.advance(0.1)
    reps = [r for r in replies if isinstance(r, input_reports.IRReport)] + ir_reports(sim)
    assert len(reps) == 11  # k = 0..10 due at t0 + k * 0.01 <= t0 + 0.1
    assert all(r.report_id == 0x33 for r in reps)


@pytest.mark.parametrize("mode_byte", [1, 3, 5, 2, 0])
@pytest.mark.parametrize("report_mode", [0x33, 0x36, 0x37, 0x3E, 0x31])
def test_mode_byte_must_match_report_mode(mode_byte, report_mode):
    sim, clock = make()
    start(sim, mode_byte=mode_byte, report_mode=report_mode)
    clock.advance(0.2)
    got = ir_reports(sim)
    matches = {1: (0x36, 0x37), 3: (0x33,), 5: (0x3E,)}.get(mode_byte, ())
    if report_mode in matches:
        assert len(got) >= 20
    else:
        assert got == []


def test_old_order_without_configure_byte_is_refused():
    # writing 0x08 first (the old WiiBrew recipe) instead of 0x01 leaves the camera silent
    sim, clock = make()
    for s in (H("13 04"), H("1A 04"), output_reports.encode_write(0xB00030, b"\x08")):
        sim.write(s)
    b1, b2 = protocol.SENSITIVITY_BLOCKS["level3"]
    for s in (
        output_reports.encode_write(0xB00000, b1),
        output_reports.encode_write(0xB0001A, b2),
        output_reports.encode_write(0xB00033, b"\x03"),
        output_reports.encode_write(0xB00030, b"\x08"),
        H("12 04 33"),
    ):
        sim.write(s)
    clock.advance(0.2)
    assert ir_reports(sim) == []


def test_unacked_enables_with_0x04_work_but_send_no_ack():
    sim, clock = make()
    sim.write(H("13 04"))
    sim.write(H("1A 04"))
    assert drain(sim) == []  # no ack requested
    start(sim, skip={0, 1})
    clock.advance(0.05)
    assert len(ir_reports(sim)) == 5


def test_blind_sensitivity_streams_without_dots():
    sim, clock = make()
    start(sim)
    sim.write(output_reports.encode_write(0xB0001A, H("FF 05")))  # gain limit above the gain: sees nothing
    clock.advance(0.1)
    reps = ir_reports(sim)
    assert reps and all(r.dots == {} for r in reps[1:])


# ---------------------------------------------------------------- registers, status, acks


def test_register_reads_return_what_was_written_in_16_byte_chunks():
    sim, _clock = make()
    start(sim, sensitivity="level5", mode_byte=3)
    sim.write(output_reports.encode_read(0xB00000, 0x34))
    replies = [input_reports.parse(r) for r in drain(sim)]
    replies = [r for r in replies if isinstance(r, input_reports.ReadReply)]
    assert [(r.offset, r.size, r.error) for r in replies] == [(0, 16, 0), (16, 16, 0), (32, 16, 0), (48, 4, 0)]
    content = b"".join(r.data for r in replies)
    assert content[0:9] == H("07 00 00 71 01 00 72 00 20")
    assert content[0x1A:0x1C] == H("1F 03")
    assert content[0x30] == 0x08 and content[0x33] == 0x03
    assert sim.register(0xB00100 + 0x33) == b"\x03"  # mirrored every 0x100 bytes


def test_malformed_writes_are_acked_with_an_error():
    sim, _ = make()
    bad_size = bytearray(output_reports.encode_write(0xB00000, b"\x01"))
    bad_size[5] = 0
    too_big = bytearray(bad_size)
    too_big[5] = 17
    for report in (
        bytes(bad_size),
        bytes(too_big),
        output_reports.encode_write(0xB00000, b"\x01")[:10],
        output_reports.encode_write(0x990000, b"\x01"),
        H("12 04"),
        H("55 00"),
    ):
        sim.write(report)
        (ack,) = [input_reports.parse(r) for r in drain(sim)]
        assert isinstance(ack, input_reports.Ack) and ack.acked_report == report[0] and ack.error != 0
    sim.write(output_reports.encode_write(0x000020, b"\x11", space=protocol.SPACE_EEPROM))
    assert input_reports.parse(drain(sim)[0]).error == 0 and sim.memory.eeprom[0x20] == 0x11


def test_status_reports_ir_flag_leds_and_battery():
    sim, _ = make(battery=0x83)
    sim.write(H("11 30"))  # LEDs 1 and 2, no ack asked
    sim.write(H("15 00"))
    (st,) = [input_reports.parse(r) for r in drain(sim)]
    assert isinstance(st, input_reports.StatusReport)
    assert (st.battery, st.leds, st.ir_enabled) == (0x83, 0x30, False)
    start(sim)
    sim.write(H("15 00"))
    st = next(r for r in (input_reports.parse(r) for r in drain(sim)) if isinstance(r, input_reports.StatusReport))
    assert st.ir_enabled and sim.leds == 0x30
    sim.write(H("13 00"))  # pixel clock off: camera off
    assert not sim.streaming


def test_rumble_and_led_state_are_tracked():
    sim, _ = make()
    sim.write(H("11 83"))  # LED 4, ack, rumble
    assert sim.leds == 0x80 and sim.rumble
    assert input_reports.parse(drain(sim)[0]).acked_report == 0x11
    sim.write(H("15 00"))
    assert not sim.rumble


def test_unsolicited_status_stops_reports_until_mode_is_sent_again():
    sim, clock = make()
    start(sim)
    clock.advance(0.05)
    drain(sim)
    sim.send_unsolicited_status()
    clock.advance(0.1)
    assert [type(input_reports.parse(r)) for r in drain(sim)] == [input_reports.StatusReport]
    sim.write(H("12 04 33"))
    clock.advance(0.05)
    assert len(ir_reports(sim)) == 6


# ---------------------------------------------------------------- timing and buffering


def test_report_k_is_due_at_t0_plus_k_times_10ms():
    sim, clock = make()
    start(sim)
    t0 = clock.now()
    counts = []
    for dt in (0.0049, 0.0052, 0.0099, 0.0301):  # cumulative 0.0049, 0.0101, 0.0200, 0.0501
        clock.advance(dt)
        counts.append(len(ir_reports(sim)))
    assert counts == [0, 1, 1, 3]
    sent = list(sim.history)
    assert [round(h.t - t0, 9) for h in sent[:6]] == [0.0, 0.01, 0.02, 0.03, 0.04, 0.05]


def test_late_reader_gets_a_bounded_buffer_oldest_dropped():
    sim, clock = make(sources=lambda t: np.array([[1.0, 0.3 - 0.1 * (t - 10.0), 0.0]]))
    start(sim)
    clock.advance(1.0)  # 100 reports due, 64 fit
    reps = ir_reports(sim)
    assert len(reps) == HID_BUFFER_SIZE
    assert sim.stats.overflowed == 100 - HID_BUFFER_SIZE  # k = 1..100 due (k = 0 was read by start())
    # the survivors are the newest: the last one shows the source at t = 1.0 s after the start
    x_last = reps[-1].dots[0][0]
    assert x_last == int(np.rint(CAM.project([[1.0, 0.3 - 0.1 * 1.0, 0.0]])[0, 0]))
    assert reps[0].dots[0][0] == int(np.rint(CAM.project([[1.0, 0.3 - 0.1 * 0.37, 0.0]])[0, 0]))


def test_realtime_mode_blocks_until_the_next_report():
    clock = SystemClock()
    sim = SimulatedWiimote(CAM, lambda t: STATIC, clock, np.random.default_rng(1), sigma_px=0.0, realtime=True)
    sim.open()
    start(sim)
    drain(sim)
    t = time.monotonic()
    r = sim.read(22, 5000)
    waited = time.monotonic() - t
    assert r and r[0] == 0x33
    assert (
        waited < 1.0
    )  # the next report is due within 10 ms, not at the 5 s timeout (a loaded machine: late, still far under)
    sim.write(H("13 00"))  # camera off: nothing comes, read times out
    drain(sim)
    t = time.monotonic()
    assert sim.read(22, 60) == b""
    assert 0.05 <= time.monotonic() - t < 5.0  # not before the timeout; after it, as soon as the machine lets it


# ---------------------------------------------------------------- dots


def test_dots_equal_the_rounded_projections_with_zero_noise():
    sim, clock = make()
    start(sim)
    clock.advance(0.1)
    truth = np.rint(CAM.project(STATIC))
    for rep in ir_reports(sim):
        assert sorted(rep.dots.values()) == sorted(map(tuple, truth.astype(int)))
        sizes = CAM.blob_sizes(STATIC)
        by_pixel = {tuple(p.astype(int)): s for p, s in zip(truth, sizes)}
        assert all(rep.sizes[s] == by_pixel[d] for s, d in rep.dots.items())


def test_pixel_noise_matches_sigma():
    sim, clock = make(sigma_px=0.5, seed=3)
    start(sim)
    truth = CAM.project(STATIC)
    errs = []
    for _ in range(100):
        clock.advance(0.1)
        drain(sim)
        for h in list(sim.history)[-10:]:
            for src, x, y in h.slots.values():
                errs.append((x - truth[src, 0], y - truth[src, 1]))
    errs = np.array(errs)
    assert len(errs) == 100 * 10 * 3
    assert np.all(np.abs(errs.mean(axis=0)) < 0.04)
    # Gaussian 0.5 px then rounding: std close to sqrt(0.25 + 1/12) = 0.577
    assert np.all(np.abs(errs.std(axis=0) - 0.577) < 0.04)


def test_at_most_four_blobs_and_slots_are_stable():
    # six sources; source 0 goes behind the camera for 0.1 s <= t - t0 < 0.2 s
    def sources(t):
        pts = np.array([[1.0, y, 0.0] for y in (0.3, 0.2, 0.1, 0.0, -0.1, -0.2)])
        if 0.1 <= t - 10.0 < 0.2:
            pts[0, 0] = -1.0
        return pts

    sim, clock = make(sources)
    start(sim)
    clock.advance(0.3)
    drain(sim)
    reps = list(sim.history)
    assert all(len(h.slots) == 4 for h in reps)
    first = {s: v[0] for s, v in reps[0].slots.items()}
    assert first == {0: 0, 1: 1, 2: 2, 3: 3}
    during = {s: v[0] for s, v in reps[15].slots.items()}
    assert during == {0: 4, 1: 1, 2: 2, 3: 3}  # the lowest free slot goes to the next source
    after = {s: v[0] for s, v in reps[25].slots.items()}
    assert after == during  # source 4 keeps slot 0; source 0 waits for a free slot


def test_full_format_alternates_halves_of_one_frame():
    sim, clock = make(sources=lambda t: np.array([[1.0, 0.3, 0.0], [1.0, 0.1, 0.0], [1.0, -0.1, 0.0]]))
    replies = start(sim, mode_byte=5, report_mode=0x3E)
    clock.advance(0.1)
    reps = [r for r in replies if isinstance(r, input_reports.IRReport)] + ir_reports(sim)
    assert [r.report_id for r in reps[:4]] == [0x3E, 0x3F, 0x3E, 0x3F]
    a, b = reps[0], reps[1]
    assert set(a.dots) == {0, 1} and set(b.dots) == {2}
    assert all(0 <= v <= 127 for bb in a.bboxes.values() for v in bb)
    assert input_reports.combine_interleaved_accel(a, b) == (512, 512, 616)
    bx = a.bboxes[0]
    assert bx[0] <= a.dots[0][0] / 8 <= bx[2] and bx[1] <= a.dots[0][1] / 8 <= bx[3]


# ---------------------------------------------------------------- faults


def test_dead_camera_ignores_the_first_start():
    sim, clock = make(faults=SimFaults(dead_starts=1))
    start(sim)
    clock.advance(0.3)
    assert ir_reports(sim) == []
    start(sim)  # reads k = 0
    clock.advance(0.05)
    assert len(ir_reports(sim)) == 5
    assert (sim.stats.starts, sim.stats.starts_ignored) == (2, 1)


def test_disconnect_raises_oserror_until_reopened_after_reconnect():
    sim, clock = make(faults=SimFaults(disconnect_at=10.5, reconnect_after=1.0))
    start(sim)
    clock.advance(0.49)
    assert len(ir_reports(sim)) == 49
    clock.advance(0.02)
    with pytest.raises(OSError):
        sim.read(22, 0)
    with pytest.raises(OSError):
        sim.write(H("15 00"))
    clock.advance(0.9)
    with pytest.raises(OSError):
        sim.open()
    clock.advance(0.2)
    sim.open()
    # back power-cycled: registers cleared, nothing streams until started again
    assert sim.register(0xB00033) == b"\x00" and not sim.camera_running
    clock.advance(0.2)
    assert drain(sim) == []
    start(sim)  # reads k = 0
    clock.advance(0.05)
    assert len(ir_reports(sim)) == 5


def test_dropped_reports_are_never_delivered():
    sim, clock = make(faults=SimFaults(drop_probability=0.3), seed=5)
    start(sim)
    n = 0
    for _ in range(100):
        clock.advance(0.01)
        n += len(ir_reports(sim))
    dropped = sim.stats.dropped
    assert 0.2 < dropped / len(sim.history) < 0.4
    assert n + dropped == len(sim.history) - 1  # minus the k = 0 report read by start()


def test_garbage_never_parses_and_real_reports_still_come():
    sim, clock = make(faults=SimFaults(garbage_probability=0.5), seed=7)
    start(sim)
    bad = good = 0
    for _ in range(200):
        clock.advance(0.01)
        for r in drain(sim):
            try:
                input_reports.parse(r)
                good += 1
            except protocol.ProtocolError:
                bad += 1
    assert bad == sim.stats.garbage and 60 < bad < 140
    assert good == 200


def test_zero_dot_faults_encode_00_on_the_wire():
    sim, clock = make(
        sources=lambda t: np.array([[1.0, 0.0, 0.0]]), faults=SimFaults(zero_missing=True, zero_first=True)
    )
    replies = start(sim)
    clock.advance(0.02)
    raw = list(drain(sim))
    first = next(r for r in replies if isinstance(r, input_reports.IRReport))
    assert first.dots == {}  # the new blob's first report: (0, 0)
    assert raw[0][6:9] != bytes(3) and raw[0][9:18] == bytes(9)  # slot 0 seen; missing slots 1-3 are 00 00 00
    assert input_reports.parse(raw[0]).dots.keys() == {0}
    assert sim.history[0].slots == {}  # the truth says: nothing was visible in that report


def test_lost_acks_are_not_sent():
    sim, _ = make(faults=SimFaults(lost_acks=2))
    replies = start(sim)
    acks = [r for r in replies if isinstance(r, input_reports.Ack)]
    assert len(acks) == 5 and sim.stats.lost_acks == 2


def test_stall_stops_the_stream_until_restarted():
    sim, clock = make(faults=SimFaults(stall_at=10.2))
    start(sim)
    clock.advance(0.5)
    assert len(ir_reports(sim)) == 20  # k = 1..20 (t0 + 0.2 is the last due before the stall)
    assert not sim.streaming
    start(sim)  # reads k = 0
    clock.advance(0.05)
    assert len(ir_reports(sim)) == 5


def test_history_records_equal_the_dataclass_constructor():
    """`_emit` sets a `SentReport`'s fields in one update: the same fields as its `__init__`
    (none missed), the slots of the dots each report carried, still frozen."""
    sim, clock = make()
    start(sim)
    clock.advance(0.2)
    ir_reports(sim)
    sent = list(sim.history)
    assert len(sent) >= 20
    for h in sent:
        built = SentReport(h.k, h.t, h.report_id, dict(h.slots), h.dropped, h.stream)
        assert set(vars(h)) == {f.name for f in dataclasses.fields(SentReport)} and h == built
        assert h.report_id == 0x33 and set(h.slots) <= {0, 1, 2, 3}
    assert any(len(h.slots) == 3 for h in sent)  # the three static sources in view
    with pytest.raises(dataclasses.FrozenInstanceError):
        sent[0].k = 1  # type: ignore[misc]
