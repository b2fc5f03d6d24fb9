"""`--ros2` and its flags: refused without it, a bad domain, namespace or config file is one line
and exit 2 before anything runs; `bench ros2` counts what a subscriber process received."""

from __future__ import annotations

import pytest

from tests.cli.test_flags import one_line_exit_2
from wiithrow.app.cli.bench import ros2 as bench_ros2
from wiithrow.app.cli.ros2_flags import ros2_node
from wiithrow.app.ros2.participant import Ros2Node

SECURED = '<CycloneDDS xmlns="https://cdds.io/config"><Domain><Security/></Domain></CycloneDDS>'
OPEN = (
    '<CycloneDDS xmlns="https://cdds.io/config"><Domain><General><Interfaces>'
    '<NetworkInterface address="0.0.0.0"/></Interfaces></General></Domain></CycloneDDS>'
)


@pytest.mark.parametrize("command", [["track", "--sim", "--duration", "0.1"], ["demo", "--duration", "0.1"], ["serve"]])
def test_ros2_flags_without_ros2_are_refused(capsys, command):
    one_line_exit_2(capsys, [*command, "--ros2-domain", "3"], "--ros2-domain does not apply without --ros2")


@pytest.mark.parametrize(
    "extra, needle",
    [
        (["--ros2-domain", "233"], "0-232, not 233"),
        (["--ros2-domain", "x"], "an integer 0-232, not 'x'"),
        (["--ros2-namespace", "/a b"], "not '/a b'"),
        (["--ros2-namespace", "/1a"], "not '/1a'"),
        (["--ros2-insecure-network"], "does not apply without --ros2-config"),
        (["--ros2-node", "7rig"], "a ROS 2 node name"),
        (["--ros2-node", "rig/7"], "not 'rig/7'"),
        (["--ros2-distro", "foxy"], "invalid choice: 'foxy'"),
    ],
)
def test_bad_ros2_values_are_one_line(capsys, extra, needle):
    one_line_exit_2(capsys, ["track", "--sim", "--duration", "0.1", "--ros2", *extra], needle)


@pytest.mark.parametrize("flag", [["--ros2-node", "rig"], ["--ros2-distro", "humble"]])
def test_the_node_flags_without_ros2_are_refused(capsys, flag):
    one_line_exit_2(capsys, ["track", "--sim", "--duration", "0.1", *flag], f"{flag[0]} does not apply without --ros2")


@pytest.mark.parametrize(
    "flags, ros_distro, expected",
    [
        ([], None, Ros2Node("wiithrow", "/lab", "jazzy")),
        ([], "humble", Ros2Node("wiithrow", "/lab", "humble")),
        ([], "kilted", Ros2Node("wiithrow", "/lab", "jazzy")),
        (["--ros2-node", "rig_7", "--ros2-distro", "humble"], "jazzy", Ros2Node("rig_7", "/lab", "humble")),
    ],
)
def test_the_node_is_named_by_its_flags_and_speaks_ros_distros_graph(monkeypatch, flags, ros_distro, expected):
    from wiithrow.app.cli.main import build_parser

    if ros_distro is None:
        monkeypatch.delenv("ROS_DISTRO", raising=False)
    else:
        monkeypatch.setenv("ROS_DISTRO", ros_distro)
    args = build_parser().parse_args(["track", "--ros2", "--ros2-namespace", "/lab", *flags])
    assert ros2_node(args, "/lab") == expected


def test_a_config_file_beyond_loopback_needs_dds_security_or_the_insecure_flag(capsys, tmp_path):
    open_file, secured, broken = tmp_path / "open.xml", tmp_path / "secured.xml", tmp_path / "broken.xml"
    open_file.write_text(OPEN)
    secured.write_text(SECURED)
    broken.write_text("<CycloneDDS><Domain>")
    base = ["track", "--sim", "--duration", "0.1", "--ros2", "--ros2-config"]
    one_line_exit_2(capsys, [*base, str(open_file)], "has no <Security> section", "--ros2-insecure-network")
    one_line_exit_2(capsys, [*base, str(broken)], "is not XML")
    one_line_exit_2(capsys, [*base, str(tmp_path / "missing.xml")], "missing.xml")
    from wiithrow.app.ros2.domain import check_config

    assert check_config(secured, insecure_network=False) == SECURED
    assert check_config(open_file, insecure_network=True) == OPEN


def test_track_publishes_as_ros2_and_says_what_it_sent(capsys):
    from wiithrow.app.cli.main import main

    assert main(["track", "--sim", "--duration", "0.5", "--ros2", "--ros2-namespace", "/track_test"]) == 0
    err = capsys.readouterr().err
    assert "ROS 2 topics under /track_test (and /tf, /tf_static) on DDS domain" in err
    assert "published 50 marker frames" in err  # 0.5 s at 100 Hz: every tracked frame


def test_bench_ros2_counts_every_frame_a_subscriber_process_received():
    figures = bench_ros2.run(seconds=2.0)
    assert figures["frames_published"] == 200  # 2 s at 100 Hz
    assert figures["frames_received"] == figures["frames_published"]
    assert figures["lost_frames"] == 0 and figures["out_of_order"] == 0
    assert 0 < figures["p50_ms"] <= figures["p99_ms"] <= figures["max_ms"]
    wake = figures["machine_wake"]  # the machine's floor over the replay's 2 s
    assert wake["count"] > 0 and 0.0 <= wake["p50_ms"] <= wake["p99_ms"] <= wake["max_ms"], wake
