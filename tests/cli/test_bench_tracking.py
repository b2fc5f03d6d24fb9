"""`wiithrow bench tracking --ros2 --foxglove` (issue 24: the figures with the publishers on): the
same seeded reports track the same frames with them attached; the figures themselves depend on
the machine's load and are the benchmark's, not the suite's."""

from __future__ import annotations

import json

from wiithrow.app.cli.main import main


def test_bench_tracking_attaches_the_ros2_and_foxglove_publishers_and_tracks_the_same(capsys):
    assert main(["bench", "tracking", "--quick", "--json"]) == 0
    alone = json.loads(capsys.readouterr().out)
    assert main(["bench", "tracking", "--quick", "--json", "--ros2", "--foxglove"]) == 0
    attached = json.loads(capsys.readouterr().out)
    assert set(alone) == set(attached) == {"remotes_2", "remotes_4"}
    for rig in ("remotes_2", "remotes_4"):
        assert attached[rig]["synced_frames"] == alone[rig]["synced_frames"] > 0
        assert attached[rig]["markers_per_frame"] == alone[rig]["markers_per_frame"] > 3.5
        assert attached[rig]["frames_per_s"] > 0
        assert attached[rig]["ros2_marker_frames"] == alone[rig]["synced_frames"]  # every frame numbered
        # the writer process wrote each frame it was not a ring behind for (and only those), and the
        # reader of markers in another process received them (best effort: no more than were written)
        written, dropped = attached[rig]["ros2_samples_written"], attached[rig]["ros2_frames_dropped"]
        assert written > 0 and written + dropped >= alone[rig]["synced_frames"]
        assert 0 < attached[rig]["ros2_frames_received"] <= written
        # the viewer subscribed to every channel: markers, dots, steps, reports (all of them unless dropped)
        assert attached[rig]["foxglove_messages"] > 0
        assert (
            attached[rig]["foxglove_messages"] + attached[rig]["foxglove_records_dropped"] > alone[rig]["synced_frames"]
        )
        assert "ros2_marker_frames" not in alone[rig] and "foxglove_messages" not in alone[rig]


def test_the_publishers_are_attached_to_bench_tracking_only(capsys):
    assert main(["bench", "record", "--ros2"]) == 2
    assert "--ros2 is for `wiithrow bench tracking` only" in capsys.readouterr().err
