"""`wiithrow bench ros2 [--seconds S]`: latency from a tracked frame to a ROS 2 subscriber in another process.

The rig of `bench publish` (two remotes, four markers on crossing paths, recorded report bytes)
is replayed at its real pace, 100 Hz; each tracked frame is handed to the ROS 2 writer process
as `--ros2` does (`Ros2ProcessPublisher`: mocap4r2 `Markers` and the `MarkerArray`, best effort,
keep last 5) the moment it comes out of the tracker, the Unix time then noted by its number. A
child process (this module's `child`, a DDS reader of `markers` on the same loopback-only domain,
a listener called by Cyclone as each sample arrives) stamps the arrival. Latency = arrival -
hand-over, both on this machine's clock: the hand-over through shared memory, the writer
process's CDR encoding, DDS over loopback UDP both ways and the child's decoding.

Figures: `p50_ms`, `p99_ms`, `max_ms` (goal: p99 <= 2 ms), `frames_published`,
`frames_received`, `lost_frames` (goal 0), `out_of_order`, `duration_s` (`--seconds`, default
60; 3 with --quick), `write_p99_ms` (the tracking thread's part: the hand-over),
`frames_dropped` (records the writer process lost), `machine_wake` (how late the machine woke a
thread over the replay's seconds: `wake_probe`, the floor under the p99), `load_average_1min`.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import time
from typing import Any

import numpy as np

from wiithrow.app.channels import registry
from wiithrow.app.channels.ros2_sink import Ros2ProcessPublisher, dds_qos
from wiithrow.app.cli.bench.timing import delivery_figures
from wiithrow.app.cli.bench.tracking import decoders_and_pipeline, recorded_reports
from wiithrow.app.cli.bench.wake_probe import WakeProbe
from wiithrow.app.errors import AppError
from wiithrow.app.ros2 import messages as m
from wiithrow.app.ros2.domain import LOOPBACK_CONFIG, Ros2Domain, topic_name
from wiithrow.clock import SimClock

GOAL_P99_MS = 2.0


def _namespace() -> str:
    return f"/bench_{os.getpid()}"


def run(quick: bool = False, seconds: float | None = None) -> dict[str, Any]:
    seconds = seconds if seconds is not None else (3.0 if quick else 60.0)
    reports, Ps = recorded_reports(seconds, np.random.default_rng(0), 2)
    clock = SimClock()
    domain_id = 100 + os.getpid() % 100
    namespace = _namespace()
    child = None
    publisher = None
    probe = WakeProbe()
    try:
        decoders, rig = decoders_and_pipeline(Ps, clock)
        publisher = Ros2ProcessPublisher(domain_id, rig.camera_names, "link1", clock=clock, namespace=namespace)
        command = [sys.executable, "-m", "wiithrow.app.cli.bench.ros2", str(domain_id), namespace]
        child = subprocess.Popen(
            command, stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True
        )
        if not publisher.wait_for_subscribers(30.0):
            raise AppError("bench ros2: the subscriber process did not match within 30 s")
        time.sleep(0.5)  # discovery both ways (the reader matches the writer too)
        write_s = []
        handed_ns: dict[int, int] = {}
        probe.begin()
        start = time.perf_counter()
        for c, t, data in reports:
            delay = start + t - time.perf_counter()
            if delay > 0:
                time.sleep(delay)
            for frame in rig.process(c, decoders[c].decode([(t, data)])):
                before = time.perf_counter()
                handed = time.time_ns()
                handed_ns[publisher.publish_markers(frame)] = handed
                write_s.append(time.perf_counter() - before)
        duration = time.perf_counter() - start
        machine_wake = probe.end()
        publisher.flush(5.0)
        time.sleep(0.2)  # the last samples on their way
        out, err = child.communicate("", timeout=60.0)
        child = None
    finally:
        probe.close()
        if child is not None:
            child.kill()
            child.wait()
        if publisher is not None:
            publisher.close()
    arrivals = [json.loads(line) for line in out.splitlines()]
    if not arrivals:
        raise AppError(f"bench ros2: the subscriber received nothing ({err.strip()[-300:]})")
    latencies = [1e3 * (a["received_ns"] - handed_ns[a["seq"]]) / 1e9 for a in arrivals]
    seqs = [a["seq"] for a in arrivals]
    return {
        **delivery_figures(latencies, seqs, publisher.markers_sent, duration),
        "write_p99_ms": float(np.percentile(1e3 * np.array(write_s), 99)),
        "frames_dropped": publisher.records_dropped,
        "machine_wake": machine_wake,
        "goal_p99_ms": GOAL_P99_MS,
    }


def child(domain_id: int, namespace: str) -> None:
    """Read `markers` until standard input closes; then print each arrival as a JSON line."""
    from cyclonedds.core import Listener, Policy
    from cyclonedds.core import Qos as DdsQos
    from cyclonedds.sub import DataReader
    from cyclonedds.topic import Topic

    domain = Ros2Domain(domain_id, LOOPBACK_CONFIG)
    participant = domain.participant
    arrivals: list[tuple[int, int]] = []

    def on_data_available(reader: Any) -> None:
        received = time.time_ns()
        for sample in reader.take(N=100):
            if isinstance(sample, m.MocapMarkers):
                arrivals.append((int(sample.frame_number), received))

    qos = DdsQos(Policy.Reliability.BestEffort, Policy.History.KeepLast(5))
    topic = Topic(participant, topic_name(namespace, "markers"), m.MocapMarkers, qos=dds_qos(registry.SENSOR_DATA_QOS))
    _reader = DataReader(participant, topic, qos=qos, listener=Listener(on_data_available=on_data_available))
    sys.stdin.read()
    time.sleep(0.2)
    for seq, received_ns in arrivals:
        print(json.dumps({"seq": seq, "received_ns": received_ns}))
    domain.close()


if __name__ == "__main__":
    child(int(sys.argv[1]), sys.argv[2])
