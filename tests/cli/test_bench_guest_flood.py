"""`wiithrow bench guest-flood --quick --json` and `--max-guests`: the flood runs, every guest
message kind is refused or admitted in lines (no traceback), the operator is notified of Stop once
per burst, the server's memory stays bounded, and the flag is checked in one line. (Timings are
the benchmark's figures, not asserted here.)"""

from __future__ import annotations

import argparse

import pytest

from tests.helpers.strict_json import loads_strict
from wiithrow.app.cli.main import main
from wiithrow.app.cli.serving import access_from_args, add_access_arguments


@pytest.mark.slow
def test_the_quick_flood_is_bounded_and_notifies_stop_once_per_burst(capsys):
    assert main(["bench", "guest-flood", "--quick", "--json"]) == 0
    captured = capsys.readouterr()
    figures = loads_strict(captured.out)
    assert "Traceback" not in captured.err
    assert figures["idle"]["pings"] > 0 and figures["flood"]["pings"] > 0
    assert figures["guest_messages_sent"] > 1000 and figures["server_stops"] > 0
    assert figures["server_refusals"]["message"] > 0 and figures["server_read_late"] > 0
    # the guests press Stop all along: one burst (a stall of the loaded machine may split it)
    assert 1 <= figures["stop_notifications"] <= 3
    assert figures["rss_growth_peak_mb"] < 200.0  # wide: the goal (50 MB) is the benchmark's
    assert {"p99_ratio", "goal_met", "limits"} <= set(figures)


def parse(*argv: str) -> argparse.Namespace:
    parser = argparse.ArgumentParser()
    parser.add_argument("--host", default="127.0.0.1")
    add_access_arguments(parser)
    return parser.parse_args(list(argv))


def test_max_guests_is_given_or_sixteen_and_checked(capsys):
    assert access_from_args(parse()).max_guests == 16
    assert access_from_args(parse("--max-guests", "0")).max_guests == 0
    for bad, why in (("-1", "0 or more"), ("many", "a whole number")):
        with pytest.raises(SystemExit):
            parse("--max-guests", bad)
        assert why in capsys.readouterr().err
