"""wiithrow's ROS 2 writer process and ROS 2-configured readers (`ros2_graph_reader`) on one host,
by default in a network namespace of their own.

    unshare -rn python -m tests.helpers.ros2_graph_scenario JSON

JSON: {"netns": bool, "domain", "namespace", "node", "distro", "cameras": [...], "configs": [...],
"seconds"}. In a fresh network namespace (`netns`) it brings loopback up and adds a veth pair
(10.200.0.1/24 and .2/24, multicast-capable, like a LAN interface: what Cyclone picks when a
configuration names none), then starts `Ros2ProcessPublisher` (the writer process `--ros2` runs)
as ROS 2 node `node` in `namespace` with graph format `distro`, writes one calibration (two
cameras: `/tf_static`), reads the writer process's UDP sockets and the IPv4 multicast memberships
of the namespace's interfaces (/proc/net/igmp) before any reader starts, runs one reader per
configuration at the same time, and prints one JSON object: `topics` (the DDS topics the
publisher writes: `Ros2ProcessPublisher.topics`), `writer_sockets` ([address, port]), `multicast_ports`, `igmp`
({interface: [group]}), `readers` ({config: what the reader printed}).
"""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path
from typing import Any

import numpy as np

from tests.helpers.sockets import process_sockets
from wiithrow.app.channels.ros2_sink import Ros2ProcessPublisher
from wiithrow.app.ros2 import ports
from wiithrow.app.ros2.participant import Ros2Node
from wiithrow.clock import SimClock

ROOT = Path(__file__).resolve().parents[2]


def _network() -> None:
    for command in (
        "ip link set lo up",
        "ip link add v0 type veth peer name v1",
        "ip addr add 10.200.0.1/24 dev v0",
        "ip addr add 10.200.0.2/24 dev v1",
        "ip link set v0 up",
        "ip link set v1 up",
    ):
        subprocess.run(command.split(), check=True)


def igmp() -> dict[str, list[str]]:
    """{interface: [IPv4 group joined on it, dotted]} (/proc/net/igmp: the groups in host order hex)."""
    groups: dict[str, list[str]] = {}
    device = ""
    for line in Path("/proc/net/igmp").read_text().splitlines()[1:]:
        fields = line.split()
        if not line.startswith(("\t", " ")):
            device = fields[1]
            groups[device] = []
        else:
            groups[device].append(".".join(str(b) for b in bytes.fromhex(fields[0])[::-1]))
    return groups


def camera_matrices() -> np.ndarray:
    """Two cameras 0.5 m either side of the origin, looking along z: their 3x4 projections."""
    return np.array([np.hstack([np.eye(3), [[x], [0.0], [0.0]]]) for x in (-0.5, 0.5)])


def main(spec: dict[str, Any]) -> dict[str, Any]:
    if spec["netns"]:
        _network()
    node = Ros2Node(spec["node"], spec["namespace"], spec["distro"])
    publisher = Ros2ProcessPublisher(
        spec["domain"], spec["cameras"], "link1", clock=SimClock(), namespace=spec["namespace"], node=node
    )
    try:
        publisher.publish_calibration(camera_matrices())
        if not publisher.flush(30.0):
            raise RuntimeError(f"the writer process did not read the calibration: {publisher.failure}")
        topics = sorted(publisher.topics)
        result: dict[str, Any] = {
            "topics": topics,
            "writer_sockets": [list(s.local) for s in process_sockets(publisher.process.pid) if s.protocol == "udp"],
            "multicast_ports": list(ports.multicast_ports(spec["domain"])),
            "igmp": igmp(),
        }
        readers = {
            config: subprocess.Popen(
                [sys.executable, "-m", "tests.helpers.ros2_graph_reader", str(spec["domain"]), config]
                + [spec["distro"], ",".join([*topics, "ros_discovery_info"]), str(spec["seconds"])],
                stdout=subprocess.PIPE,
                stderr=subprocess.PIPE,
                text=True,
                cwd=ROOT,
            )
            for config in spec["configs"]
        }
        result["readers"] = {}
        for config, reader in readers.items():
            out, err = reader.communicate(timeout=spec["seconds"] + 60)
            result["readers"][config] = json.loads(out) if reader.returncode == 0 else {"error": err[-2000:]}
        return result
    finally:
        publisher.close()


if __name__ == "__main__":
    print(json.dumps(main(json.loads(sys.argv[1]))), flush=True)
