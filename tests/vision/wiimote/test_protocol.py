"""Wiimote HID protocol: hand-written byte vectors from the WiiBrew layouts, round trips, errors."""

from __future__ import annotations

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from wiithrow.vision.errors import VisionError
from wiithrow.vision.wiimote import input_reports, ir_dots, output_reports, protocol
from wiithrow.vision.wiimote.input_reports import parse
from wiithrow.vision.wiimote.protocol import Button, IRFormat, ProtocolError

H = bytes.fromhex

# ---------------------------------------------------------------- output reports, by hand


def test_output_reports_known_bytes():
    assert output_reports.encode_leds(0x10) == H("11 10")
    assert output_reports.encode_leds(0x20 | 0x80) == H("11 A0")
    assert output_reports.encode_leds(0x10, rumble=True) == H("11 11")
    assert [protocol.player_leds(n) for n in (1, 2, 3, 4)] == [0x10, 0x20, 0x40, 0x80]
    assert output_reports.encode_report_mode(0x33) == H("12 04 33")
    assert output_reports.encode_report_mode(0x3E) == H("12 04 3E")
    assert output_reports.encode_report_mode(0x37, continuous=False) == H("12 00 37")
    assert output_reports.encode_ir_pixel_clock() == H("13 06")
    assert output_reports.encode_ir_logic() == H("1A 06")
    assert output_reports.encode_ir_pixel_clock(ack=False) == H("13 04")
    assert output_reports.encode_ir_logic(False, ack=False) == H("1A 00")
    assert output_reports.encode_status_request() == H("15 00")
    assert output_reports.encode_status_request(rumble=True) == H("15 01")
    assert output_reports.encode_rumble(True) == H("10 01")
    assert output_reports.encode_read(0xB00000, 0x20) == H("17 04 B0 00 00 00 20")
    assert output_reports.encode_read(0x0016, 0x1000, space=protocol.SPACE_EEPROM) == H("17 00 00 00 16 10 00")


def test_register_write_is_22_bytes_zero_padded():
    w = output_reports.encode_write(0xB00030, b"\x01")
    assert w == H("16 04 B0 00 30 01 01" + " 00" * 15)
    assert len(w) == 22
    w = output_reports.encode_write(0xB00000, protocol.SENSITIVITY_BLOCKS["level3"][0])
    assert w == H("16 04 B0 00 00 09 02 00 00 71 01 00 AA 00 64" + " 00" * 7)
    w = output_reports.encode_write(0xB0001A, H("63 03"))
    assert w == H("16 04 B0 00 1A 02 63 03" + " 00" * 14)
    assert len(output_reports.encode_write(0xA20001, bytes(range(16)))) == 22


def test_start_sequence_is_the_kernel_order():
    steps = output_reports.ir_start_sequence("level3", "extended")
    assert [s.report for s in steps] == [
        H("13 06"),
        H("1A 06"),
        H("16 04 B0 00 30 01 01" + " 00" * 15),
        H("16 04 B0 00 00 09 02 00 00 71 01 00 AA 00 64" + " 00" * 7),
        H("16 04 B0 00 1A 02 63 03" + " 00" * 14),
        H("16 04 B0 00 33 01 03" + " 00" * 15),
        H("16 04 B0 00 30 01 08" + " 00" * 15),
        H("12 04 33"),
    ]
    assert [s.expects_ack for s in steps] == [True] * 7 + [False]
    assert output_reports.ir_start_sequence("max", "full")[-1].report == H("12 04 3E")
    assert output_reports.ir_start_sequence("marcan", "basic", 0x36)[5].report[6] == 1
    with pytest.raises(ProtocolError, match="0x33"):
        output_reports.ir_start_sequence("level3", "basic", 0x33)


def test_sensitivity_table_matches_design():
    expected = {
        "level1": ("02 00 00 71 01 00 64 00 FE", "FD 05"),
        "level2": ("02 00 00 71 01 00 96 00 B4", "B3 04"),
        "level3": ("02 00 00 71 01 00 AA 00 64", "63 03"),
        "level4": ("02 00 00 71 01 00 C8 00 36", "35 03"),
        "level5": ("07 00 00 71 01 00 72 00 20", "1F 03"),
        "marcan": ("00 00 00 00 00 00 90 00 C0", "40 00"),
        "max": ("00 00 00 00 00 00 FF 00 0C", "00 00"),
    }
    assert set(protocol.SENSITIVITY_BLOCKS) == set(expected)
    for name, (b1, b2) in expected.items():
        assert protocol.sensitivity_blocks(name) == (H(b1), H(b2))
        assert protocol.sensitivity_name(H(b1), H(b2)) == name
    assert protocol.sensitivity_name(H("00" * 9), H("00 00")) is None
    with pytest.raises(ProtocolError, match="level6"):
        protocol.sensitivity_blocks("level6")


def test_ir_modes_and_report_modes():
    assert (IRFormat.BASIC.value, IRFormat.EXTENDED.value, IRFormat.FULL.value) == (1, 3, 5)
    assert protocol.REPORT_MODES[IRFormat.BASIC] == (0x36, 0x37)
    assert protocol.REPORT_MODES[IRFormat.EXTENDED] == (0x33,)
    assert protocol.REPORT_MODES[IRFormat.FULL] == (0x3E,)
    assert protocol.ir_format_of_report_mode(0x3F) is IRFormat.FULL
    assert protocol.ir_format_of_report_mode(0x30) is None
    assert IRFormat.from_name("Full") is IRFormat.FULL
    with pytest.raises(ProtocolError, match="basic, extended, full"):
        IRFormat.from_name("fancy")


def test_encoders_refuse_what_cannot_be_sent():
    with pytest.raises(ProtocolError, match="1-16"):
        output_reports.encode_write(0xB00000, bytes(17))
    with pytest.raises(ProtocolError, match="1-16"):
        output_reports.encode_write(0xB00000, b"")
    with pytest.raises(ProtocolError, match="24 bits"):
        output_reports.encode_write(0x1000000, b"\x01")
    with pytest.raises(ProtocolError):
        output_reports.encode_leds(0x01)
    with pytest.raises(ProtocolError):
        output_reports.encode_report_mode(0x22)
    with pytest.raises(ProtocolError):
        protocol.player_leds(5)
    with pytest.raises(ProtocolError, match="0-15"):
        ir_dots.encode_dot_extended((1, 1), 16)
    assert issubclass(ProtocolError, VisionError) and issubclass(ProtocolError, ValueError)


# ---------------------------------------------------------------- dot formats, by hand


def test_extended_dot_known_bytes():
    # x = 0x1A3, y = 0x2C5, size 3: [x lo, y lo, y hi << 6 | x hi << 4 | size]
    assert ir_dots.encode_dot_extended((0x1A3, 0x2C5), 3) == H("A3 C5 93")
    assert ir_dots.encode_dot_extended(None) == H("FF FF FF")


def test_basic_pair_known_bytes():
    # x1 = 0x1A3, y1 = 0x2C5, x2 = 0x0F0, y2 = 0x201 -> [A3, C5, 10 01 10 00, F0, 01]
    ir = ir_dots.encode_dots_basic({0: (0x1A3, 0x2C5), 1: (0x0F0, 0x201)})
    assert ir[:5] == H("A3 C5 98 F0 01")
    assert ir[5:] == H("FF FF FF FF FF")  # slots 2, 3 missing: x = y = 1023
    assert ir_dots.decode_dots_basic(H("A3 C5 98 F0 2C" + "FF" * 5)) == {0: (0x1A3, 0x2C5), 1: (0x0F0, 0x22C)}
    assert ir_dots.decode_dots_basic(H("A3 C5 9C F0 01" + "FF" * 5)) == {0: (0x1A3, 0x2C5)}  # y2 = 0x301 > 767


def test_full_dot_known_bytes():
    dot = ir_dots.encode_dot_full((0x1A3, 0x2C5), 3, (0x34, 0x58, 0x36, 0x5A), 0x7F)
    assert dot == H("A3 C5 93 34 58 36 5A 00 7F")
    assert ir_dots.encode_dot_full(None) == H("FF" * 9)


def test_parse_extended_report_by_hand():
    # 0x33: BB BB XX YY ZZ + 4 dots of 3 bytes. Home pressed; accel LSBs x=3 (b0 0x60), y bit 1 (b1 0x20).
    rep = parse(H("33 60 A0 80 81 9AA3 C5 93FF FF FF00 00 00FE FF B5"))
    assert rep.report_id == 0x33
    assert rep.buttons == Button.HOME
    assert rep.accel == (0x80 << 2 | 3, 0x81 << 2 | 2, 0x9A << 2)
    assert rep.dots == {0: (0x1A3, 0x2C5), 3: (1022, 767)}  # FF.. and (0, 0) are missing
    assert rep.sizes == {0: 3, 3: 5}
    assert rep.ir_format is IRFormat.EXTENDED


def test_parse_basic_reports_by_hand():
    ir = "A3 C5 98 F0 01FF FF FF FF FF"
    rep36 = parse(H("36 08 02" + ir + "00" * 9))  # Up, One
    assert rep36.buttons == Button.UP | Button.ONE
    assert rep36.dots == {0: (0x1A3, 0x2C5), 1: (0x0F0, 0x201)}
    assert rep36.sizes == {} and rep36.accel is None
    rep37 = parse(H("37 00 00 80 80 80" + ir + "00" * 6))
    assert rep37.dots == rep36.dots and rep37.accel == (512, 512, 512)


def test_parse_interleaved_pair_by_hand():
    # Z = 0xB6: 0x3E carries Z bits 4-5 (11) in b0 bits 5-6 and bits 6-7 (10) in b1 bits 5-6,
    # 0x3F carries Z bits 0-1 (10) in b0 and bits 2-3 (01) in b1.
    a = parse(H("3E 60 48 91A3 C5 93 34 58 36 5A 00 7F" + "FF" * 9))
    b = parse(H("3F 40 20 70" + "FF" * 9 + "10 20 32 01 04 03 05 00 C8"))
    assert a.buttons == Button.A and b.buttons == Button.NONE
    assert a.dots == {0: (0x1A3, 0x2C5)} and a.sizes == {0: 3}
    assert a.bboxes == {0: (0x34, 0x58, 0x36, 0x5A)} and a.intensities == {0: 0x7F}
    assert b.dots == {3: (0x310, 0x020)} and b.sizes == {3: 2}  # 0x32 = y hi 00, x hi 11, size 2
    assert b.bboxes == {3: (1, 4, 3, 5)} and b.intensities == {3: 0xC8}
    assert a.slots == (0, 1) and b.slots == (2, 3)
    assert input_reports.combine_interleaved_accel(a, b) == (0x91 << 2, 0x70 << 2, 0xB6 << 2)


def test_parse_status_ack_read_reply_by_hand():
    st_ = parse(H("20 00 08 18 00 00 C8"))
    assert isinstance(st_, input_reports.StatusReport)
    assert st_.buttons == Button.A and st_.ir_enabled and st_.leds == 0x10 and st_.battery == 0xC8
    assert not st_.battery_low and not st_.extension
    ack = parse(H("22 00 00 16 00"))
    assert isinstance(ack, input_reports.Ack) and (ack.acked_report, ack.error) == (0x16, 0)
    assert parse(H("22 00 00 13 03")).error == 3
    rr = parse(H("21 00 00 10 00 1A 63 03" + "00" * 14))
    assert isinstance(rr, input_reports.ReadReply)
    assert (rr.size, rr.error, rr.offset, rr.data) == (2, 0, 0x001A, H("63 03"))
    bad = parse(H("21 00 00 F8 00 00" + "00" * 16))
    assert bad.error == 8 and bad.data == b""


def test_buttons_ignore_accel_bits():
    assert parse(H("30 1F 9F")).buttons == (
        Button.LEFT
        | Button.RIGHT
        | Button.DOWN
        | Button.UP
        | Button.PLUS
        | Button.TWO
        | Button.ONE
        | Button.B
        | Button.A
        | Button.MINUS
        | Button.HOME
    )
    assert parse(H("30 60 60")).buttons == Button.NONE
    assert parse(H("31 00 00 80 80 80")).accel == (512, 512, 512)


# ---------------------------------------------------------------- missing dots


@pytest.mark.parametrize(
    "ir, missing",
    [
        ("FF FF FF", True),
        ("00 00 00", True),  # (0, 0): newer remotes before the first measurement
        ("FF 10 30", True),  # x = 1023
        ("10 FF C0", True),  # y = 1023
        ("10 20 80", False),  # (0x010, 0x220): a real dot
        ("00 01 00", False),  # (0, 1) is a real dot, only (0, 0) is missing
    ],
)
def test_missing_dots_are_absent(ir, missing):
    rep = parse(H("33 00 00 80 80 80" + ir + "FF" * 9))
    assert (0 not in rep.dots) is missing


def test_y_beyond_the_sensor_is_missing():
    rep = parse(H("33 00 00 80 80 8010 20 C0" + "FF" * 9))  # y = 0x320 = 800
    assert rep.dots == {}
    rep = parse(H("33 00 00 80 80 8010 FF 80" + "FF" * 9))  # y = 0x2FF = 767
    assert rep.dots == {0: (0x10, 767)}


# ---------------------------------------------------------------- malformed input


@pytest.mark.parametrize(
    "data, pattern",
    [
        (b"", "empty"),
        (H("99 00 00"), "0x99"),
        (H("33 00 00"), r"0x33 must be 18 bytes .*got 3"),
        (H("22 00 00 16"), r"0x22 must be 5 bytes .*got 4"),
        (H("3e") + bytes(25), r"0x3e must be 22 bytes .*got 26"),
        (H("20") + bytes(7), r"0x20 must be 7 bytes .*got 8"),
    ],
)
def test_malformed_reports_raise_protocol_error(data, pattern):
    with pytest.raises(ProtocolError, match=pattern):
        parse(data)


@pytest.mark.parametrize("thing", [None, 7, "33", 1.5, [256], [-1], [0x33, "x"], object()])
def test_non_bytes_raise_protocol_error(thing):
    with pytest.raises(ProtocolError):
        parse(thing)


def test_windows_padding_to_22_bytes_is_accepted():
    ack = parse(H("22 00 00 16 00") + bytes(17))
    assert isinstance(ack, input_reports.Ack) and ack.acked_report == 0x16
    rep = parse(input_reports.encode_ir_report(0x33, {1: (5, 6)}, sizes={1: 2}) + bytes(4))
    assert rep.dots == {1: (5, 6)}
    assert parse([0x22, 0, 0, 0x16, 0]).acked_report == 0x16  # hidapi hands out lists


# ---------------------------------------------------------------- round trips

xs = st.integers(0, 1022)
ys = st.integers(0, 767)
dot = st.tuples(xs, ys).filter(lambda d: d != (0, 0))
slot_dots = st.dictionaries(st.integers(0, 3), dot, max_size=4)
buttons = st.sets(st.sampled_from([b for b in Button if b]), max_size=4).map(lambda s: Button(sum(int(b) for b in s)))
accel = st.tuples(
    st.integers(0, 1023), st.integers(0, 511).map(lambda v: 2 * v), st.integers(0, 511).map(lambda v: 2 * v)
)


@settings(derandomize=True, max_examples=300, deadline=None)
@given(slot_dots, buttons, accel, st.sampled_from([0x36, 0x37]))
def test_round_trip_basic(dots, btn, acc, rid):
    rep = parse(input_reports.encode_ir_report(rid, dots, buttons=btn, accel=acc))
    assert rep.report_id == rid and rep.dots == dots and rep.buttons == btn
    assert rep.accel == (acc if rid == 0x37 else None)


@settings(derandomize=True, max_examples=300, deadline=None)
@given(slot_dots, st.data(), buttons, accel)
def test_round_trip_extended(dots, data, btn, acc):
    sizes = {s: data.draw(st.integers(0, 15)) for s in dots}
    rep = parse(input_reports.encode_ir_report(0x33, dots, sizes=sizes, buttons=btn, accel=acc))
    assert (rep.dots, rep.sizes, rep.buttons, rep.accel) == (dots, sizes, btn, acc)


@settings(derandomize=True, max_examples=300, deadline=None)
@given(slot_dots, st.data(), buttons, accel)
def test_round_trip_full(dots, data, btn, acc):
    sizes = {s: data.draw(st.integers(0, 15)) for s in dots}
    bboxes = {s: data.draw(st.tuples(*[st.integers(0, 127)] * 4)) for s in dots}
    inten = {s: data.draw(st.integers(0, 255)) for s in dots}
    kw = {"sizes": sizes, "bboxes": bboxes, "intensities": inten, "buttons": btn, "accel": acc}
    a = parse(input_reports.encode_ir_report(0x3E, dots, **kw))
    b = parse(input_reports.encode_ir_report(0x3F, dots, **kw))
    assert {**a.dots, **b.dots} == dots
    assert {**a.sizes, **b.sizes} == sizes
    assert {**a.bboxes, **b.bboxes} == bboxes
    assert {**a.intensities, **b.intensities} == inten
    assert a.buttons == btn == b.buttons
    assert input_reports.combine_interleaved_accel(a, b) == tuple((v >> 2) << 2 for v in acc)  # 8 bits each


@settings(derandomize=True, max_examples=200, deadline=None)
@given(buttons, st.integers(0, 255), st.integers(0, 255), st.integers(0, 255), st.integers(0, 15))
def test_round_trip_status_ack(btn, flags, battery, rid, err):
    s = parse(input_reports.encode_status(btn, flags, battery))
    assert (s.buttons, s.flags, s.battery) == (btn, flags, battery)
    a = parse(input_reports.encode_ack(rid, err, buttons=btn))
    assert (a.buttons, a.acked_report, a.error) == (btn, rid, err)


@settings(derandomize=True, max_examples=200, deadline=None)
@given(st.integers(0, 0xFFFFFF), st.binary(min_size=1, max_size=16), st.integers(0, 15))
def test_round_trip_read_reply(address, data, err):
    r = parse(input_reports.encode_read_reply(address, data, error=err))
    assert r.offset == address & 0xFFFF and r.error == err
    assert r.data == (b"" if err else data)
