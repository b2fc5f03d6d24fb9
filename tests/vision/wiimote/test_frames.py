"""Send-time estimates of IR reports read in batches (`vision/wiimote/frames.py`), and the frames
and reports the hot path builds without their dataclasses' `__init__`.

The race of issue 21 ("camera 0: frame at t=... s is older than the previous one", the demo's
status line from its start and `track --sim --realtime` dying at start on a loaded machine): a
batch read late holds more reports than the time since the last read spans, `device_times` spaces
them back 10 ms apiece from the newest, and its first lands before the previous batch's last,
which the remote sent earlier. The synchroniser refuses a frame older than the one before.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from wiithrow.vision.sync import FrameSynchronizer
from wiithrow.vision.wiimote.driver_settings import DriverStats
from wiithrow.vision.wiimote.frames import REPORT_PERIOD_S, FrameAssembler, IRFrame, device_times
from wiithrow.vision.wiimote.input_reports import IRReport, encode_ir_report, parse
from wiithrow.vision.wiimote.protocol import IN_BUTTONS_ACCEL_IR12, IRFormat


def _batch(t_read: float, count: int):
    report = parse(encode_ir_report(IN_BUTTONS_ACCEL_IR12, {0: (500, 400)}, sizes={0: 3}))
    return [(t_read, report)] * count


def _frames(batches):
    assembler = FrameAssembler(DriverStats())
    out = []
    for t_read, count in batches:
        parsed = _batch(t_read, count)
        for (t_arr, rep), t_dev in zip(parsed, device_times(parsed, t_read)):
            frame = assembler.add(rep, t_arr, t_dev)
            if frame is not None:
                out.append(frame)
    return out, assembler


def test_a_late_batch_never_sends_a_report_before_the_previous_batch_did():
    # one report read at 1.000 s; the next read, 20 ms later, finds 5 (a loaded reader, or a link that
    # bunched them): spaced back from 1.020 s, the first would be sent at 0.980 s, before 1.000 s
    frames, _ = _frames([(1.000, 1), (1.020, 5), (1.030, 1)])
    t = np.array([f.t_device for f in frames])
    assert np.all(np.diff(t) > 0), np.round(t, 4)
    assert np.all(t <= np.array([f.t for f in frames]) + 1e-5)  # never sent after it arrived (but for the us steps)
    sync = FrameSynchronizer(2)
    for f in frames:  # what the rig does with them: no "older than the previous one"
        sync.push(0, f.t_device, f.dots)


def test_batches_that_fit_their_time_keep_the_10_ms_spacing_and_count_no_loss():
    frames, assembler = _frames([(1.000, 1), (1.030, 3), (1.050, 2)])
    t = np.array([f.t_device for f in frames])
    assert np.allclose(np.diff(t), REPORT_PERIOD_S)
    assert assembler.stats.drops_detected == 0


def test_reports_that_arrive_before_the_previous_one_start_a_new_timeline():
    """Recorded reports decoded again from their start (a benchmark's warm-up, a replay's next
    loop) keep their own times: nothing of the old timeline is carried over."""
    frames, _ = _frames([(1.000, 1), (1.010, 1), (0.000, 1), (0.010, 1)])
    assert [round(f.t_device, 6) for f in frames] == [1.0, 1.01, 0.0, 0.01]


def _same_fields(made, built) -> bool:
    """`made` (set in one dictionary update) holds exactly `built`'s fields (the dataclass's
    `__init__`), equal values, arrays equal and with NaN where `built` has it."""
    if type(made) is not type(built) or set(vars(made)) != {f.name for f in dataclasses.fields(built)}:
        return False
    for name, value in vars(built).items():
        other = getattr(made, name)
        if isinstance(value, np.ndarray):
            if not (other.dtype == value.dtype and np.array_equal(other, value, equal_nan=True)):
                return False
        elif other != value:
            return False
    return True


def test_a_frame_made_by_the_assembler_equals_the_dataclass_constructor():
    """`FrameAssembler._frame` sets an `IRFrame`'s fields in one update, and `parse` a 0x33
    report's: the same fields and values as their `__init__` (which also checks that no field
    added later is missed), and still frozen."""
    rng = np.random.default_rng(7)
    assembler = FrameAssembler(DriverStats())
    for k in range(200):
        dots = {s: (int(rng.integers(1, 1023)), int(rng.integers(1, 768))) for s in range(4) if rng.random() < 0.7}
        sizes = {s: int(rng.integers(0, 16)) for s in dots}
        accel = tuple(int(v) for v in rng.integers(0, 1024, 3))
        rep = parse(
            encode_ir_report(IN_BUTTONS_ACCEL_IR12, dots, sizes=sizes, buttons=int(rng.integers(0, 2)), accel=accel)
        )
        built_rep = IRReport(
            rep.report_id, rep.buttons, IRFormat.EXTENDED, dict(rep.dots), dict(rep.sizes), accel=rep.accel
        )
        assert _same_fields(rep, built_rep) and rep == built_rep
        assert rep.dots == dots and rep.sizes == sizes
        seq = assembler._seq
        frame = assembler.add(rep, 0.01 * k, 0.01 * k)
        d, s = np.full((4, 2), np.nan), np.full(4, np.nan)
        for slot, xy in dots.items():
            d[slot], s[slot] = xy, sizes[slot]
        built = IRFrame(0.01 * k, 0.01 * k, seq, IN_BUTTONS_ACCEL_IR12, d, s, rep.buttons, rep.accel)
        assert _same_fields(frame, built)
    with pytest.raises(dataclasses.FrozenInstanceError):
        frame.t = 1.0  # type: ignore[misc]
