"""`wiithrow bench soak`: its options as a user gives them, and the slope it reports. (The run
itself takes minutes of real time: its figures are in the closing notes, not in the suite.)"""

from __future__ import annotations

import math

import numpy as np
import pytest

from wiithrow.app.cli.bench.soak import slope_mb_per_h
from wiithrow.app.cli.main import main


@pytest.mark.parametrize(
    "argv, why",
    [
        (["bench", "dashboard", "--minutes", "5"], "--minutes is for `wiithrow bench soak` only"),
        (["bench", "soak", "--minutes", "0"], "--minutes must be > 0, got 0"),
        (["bench", "soak", "--minutes", "-3"], "--minutes must be > 0, got -3"),
    ],
)
def test_minutes_is_checked_in_one_line(argv, why, capsys):
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert why in err and len(err.strip().splitlines()) == 1


def test_the_slope_is_mb_per_hour_after_the_warm_up():
    rng = np.random.default_rng(0)
    t = np.arange(0.0, 1800.0, 10.0)  # 30 min, a sample every 10 s
    rss = 340.0 + 5.0 * t / 3600.0 + rng.normal(0.0, 0.2, t.size)  # 5 MB/h, 0.2 MB of noise
    assert slope_mb_per_h(t, rss) == pytest.approx(5.0, abs=0.5)
    assert slope_mb_per_h(t, np.full(t.size, 340.0)) == pytest.approx(0.0, abs=1e-9)
    assert math.isnan(slope_mb_per_h(t[:2], rss[:2]))
