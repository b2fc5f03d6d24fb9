"""Whose frames are adopted (`wiithrow.app.network.source_pin.SourcePin`), frame by frame on a
stated arrival clock: nothing without the operator (or a named source), a stream offered once it
sent `FOLLOW_FRAMES` in order and no longer once silent, a copy of the followed stream's frames
refused without touching it, a jump of it offered to the operator again, the candidates bounded."""

from __future__ import annotations

import pytest

from wiithrow.app.errors import AppError
from wiithrow.app.network.marker_checks import Refused
from wiithrow.app.network.messages import Origin
from wiithrow.app.network.source_pin import (
    CANDIDATE_TIMEOUT_S,
    FOLLOW_FRAMES,
    MAX_CANDIDATES,
    MAX_T_STEP_S,
    SourcePin,
)


def send(pin: SourcePin, source: str, stream: str, frames: range, t0: float = 0.0, arrival0: float = 100.0) -> list:
    """Frames seq in `frames` 10 ms apart (t and arrival); what each gave: a notice, or the Refused."""
    out = []
    for seq in frames:
        try:
            out.append(pin.judge(source, stream, seq, t0 + 0.01 * seq, arrival0 + 0.01 * seq))
        except Refused as refused:
            out.append(refused)
    return out


def reasons(results: list) -> set[str]:
    return {r.reason for r in results if isinstance(r, Refused)}


def test_nothing_is_followed_until_the_operator_confirms_a_stream():
    pin = SourcePin()
    pin.tell_origin("aa", "s1", Origin("tracker", 42, "wiithrow track --publish"))
    results = send(pin, "aa", "s1", range(FOLLOW_FRAMES + 5))
    assert reasons(results) == {"other_source"} and pin.pinned is None
    now = 100.0 + 0.01 * (FOLLOW_FRAMES + 4)
    [offered] = pin.candidates(now)
    assert (offered.source, offered.stream, offered.frames) == ("aa", "s1", FOLLOW_FRAMES + 5)
    assert offered.origin == Origin("tracker", 42, "wiithrow track --publish")
    assert pin.notices == [
        "source aa, stream s1 (host tracker, pid 42: wiithrow track --publish) asks to be followed: its markers "
        "are not used until the operator confirms it (the dashboard's Marker source folder)"
    ]
    assert pin.adopt("aa", "s1", now).endswith("(confirmed by the operator)")
    assert send(pin, "aa", "s1", range(FOLLOW_FRAMES + 5, FOLLOW_FRAMES + 8)) == ["", "", ""]
    assert pin.candidates(now) == []


def test_a_stream_is_offered_only_after_frames_in_order_and_while_it_sends():
    pin = SourcePin()
    send(pin, "aa", "s1", range(FOLLOW_FRAMES - 1))
    assert pin.candidates(100.1) == [] and not pin.notices  # one frame short
    with pytest.raises(AppError, match="does not ask to be followed now"):
        pin.adopt("aa", "s1", 100.1)
    send(pin, "aa", "s1", range(FOLLOW_FRAMES - 1, FOLLOW_FRAMES))
    assert len(pin.candidates(100.1)) == 1
    silent_from = 100.0 + 0.01 * (FOLLOW_FRAMES - 1)
    assert pin.candidates(silent_from + CANDIDATE_TIMEOUT_S + 0.01) == []  # it stopped: no longer offered
    with pytest.raises(AppError, match="does not ask to be followed now"):
        pin.adopt("aa", "s1", silent_from + CANDIDATE_TIMEOUT_S + 0.01)


def test_the_named_source_is_followed_at_its_first_frame_and_no_other_is_offered():
    pin = SourcePin(named_source="aa")
    assert send(pin, "aa", "s1", range(1)) == ["following source aa, stream s1 (the one named with --markers-source)"]
    results = send(pin, "bb", "s2", range(3 * FOLLOW_FRAMES))
    assert reasons(results) == {"other_source"} and pin.candidates(101.0) == []


def test_a_copy_of_the_followed_streams_frames_changes_nothing_and_a_jump_needs_the_operator():
    pin = SourcePin(named_source="aa")
    send(pin, "aa", "s1", range(50))
    pinned = pin.pinned
    assert pinned is not None and pinned.seq == 49
    # copies of frames it sent (or late ones): refused as seq, the stream untouched, nothing offered
    copies = send(pin, "aa", "s1", range(40, 50))
    assert reasons(copies) == {"seq"} and pinned.seq == 49 and pin.candidates(101.0) == []
    assert send(pin, "aa", "s1", range(50, 52)) == ["", ""]  # it goes on
    # a jump (paused longer than MAX_T_STEP_S): refused, and offered to the operator once in order
    t_jump = 0.01 * 51 + MAX_T_STEP_S + 5.0
    jumped = send(pin, "aa", "s1", range(52, 52 + FOLLOW_FRAMES), t0=t_jump - 0.52, arrival0=200.0)
    assert reasons(jumped) == {"seq"} and pinned.seq == 51
    [offered] = pin.candidates(200.0 + 0.01 * (52 + FOLLOW_FRAMES))
    assert offered.followed and offered.stream == "s1"
    assert pin.notices and "asks to be followed" in pin.notices[-1]
    pin.adopt("aa", "s1", 200.0 + 0.01 * (52 + FOLLOW_FRAMES))
    assert send(pin, "aa", "s1", range(52 + FOLLOW_FRAMES, 54 + FOLLOW_FRAMES), t0=t_jump - 0.52, arrival0=200.0) == [
        "",
        "",
    ]


def test_the_candidates_are_bounded():
    pin = SourcePin()
    for k in range(3 * MAX_CANDIDATES):
        send(pin, f"s{k:02d}", "x", range(FOLLOW_FRAMES), arrival0=100.0 + k)
    offered = pin.candidates(100.0 + 3 * MAX_CANDIDATES)
    assert len(pin._series) == MAX_CANDIDATES and len(offered) <= MAX_CANDIDATES
    assert offered[-1].source == f"s{3 * MAX_CANDIDATES - 1:02d}"  # the stalest were forgotten
