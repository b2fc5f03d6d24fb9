"""wiithrow is a ROS 2 node to ROS 2's tools on the same host: a reader configured as rmw_cyclonedds
configures a node for Humble's `ROS_LOCALHOST_ONLY=1` (with loopback multicast, and as Cyclone
0.10 runs it without) and for Jazzy's `ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST`, in another
process, discovers every topic of the `--ros2` writer process, reads its participant's
`enclave=/;`, each writer's type hash, and its `ros_discovery_info` sample, decoded with ROS 2's
own `rmw_dds_common` definitions (rosbags), naming the node as configured and listing exactly the
discovered writers' GIDs in that distribution's GID form; `/tf_static` arrives and decodes. The
writer process and the readers run in a network namespace of their own (`unshare -rn`) with a
LAN-like interface beside loopback, where that works; else on this host's loopback (said)."""

from __future__ import annotations

import json
import subprocess
import sys
from functools import cache
from pathlib import Path
from typing import Any

import pytest

from wiithrow.app.ros2 import discovery
from wiithrow.app.ros2 import messages as m
from wiithrow.app.ros2.loopback_bind import MULTICAST_GROUP
from wiithrow.app.ros2.participant import GID_BYTES
from wiithrow.app.ros2.type_hash import type_hash

ROOT = Path(__file__).resolve().parents[2]
NODE, NAMESPACE, CAMERAS = "rig_7", "/lab", ["wiimote0", "wiimote1"]
#: How long a reader may take to see everything (it stops as soon as it has).
READER_DEADLINE_S = 60.0


@cache
def network_namespace() -> bool:
    """Whether `unshare -rn` (a user and network namespace) works here."""
    try:
        return subprocess.run(["unshare", "-rn", "true"], capture_output=True, timeout=30).returncode == 0
    except (OSError, subprocess.TimeoutExpired):
        return False


def scenario(distro: str, configs: list[str], domain: int) -> dict[str, Any]:
    spec = {
        "netns": network_namespace(),
        "domain": domain,
        "namespace": NAMESPACE,
        "node": NODE,
        "distro": distro,
        "cameras": CAMERAS,
        "configs": configs,
        "seconds": READER_DEADLINE_S,
    }
    command = [sys.executable, "-m", "tests.helpers.ros2_graph_scenario", json.dumps(spec)]
    if spec["netns"]:
        command = ["unshare", "-rn", *command]
    else:
        print("unshare -rn does not work here: the writer and the readers run on this host's loopback")
    run = subprocess.run(command, capture_output=True, text=True, cwd=ROOT, timeout=READER_DEADLINE_S + 180)
    assert run.returncode == 0, run.stderr[-3000:]
    return json.loads(run.stdout)


#: Every DDS topic the writer process writes for the two cameras, and its type: the registry's
#: channels with a ROS 2 form (markers twice, each camera's dots, joint states, the trajectory, the
#: throws, the URDF, /tf and /tf_static: 10 writers, beside the node's ros_discovery_info).
TOPICS = {
    f"rt{NAMESPACE}/markers": m.MocapMarkers,
    f"rt{NAMESPACE}/markers/visualization": m.MarkerArray,
    **{f"rt{NAMESPACE}/cameras/{camera}/dots": m.PointCloud for camera in CAMERAS},
    f"rt{NAMESPACE}/joint_states": m.JointState,
    f"rt{NAMESPACE}/arm/trajectory": m.JointTrajectory,
    f"rt{NAMESPACE}/throws": m.String,
    f"rt{NAMESPACE}/robot_description": m.String,
    "rt/tf": m.TFMessage,
    "rt/tf_static": m.TFMessage,
}


def expected_kind(topic: str, distro: str) -> type:
    if topic == "ros_discovery_info":
        return discovery.FORMS[distro][2]
    return TOPICS[topic]


@pytest.mark.parametrize(
    "distro, configs, domain",
    [
        ("humble", ["humble-localhost", "humble-localhost-no-multicast"], 7),
        ("jazzy", ["jazzy-localhost"], 8),
    ],
)
def test_a_ros2_node_configured_for_this_host_matches_our_topics_and_sees_our_node(distro, configs, domain):
    if not network_namespace():
        domain = 180 + domain  # this host's loopback: away from other ROS 2 traffic's usual domains
    result = scenario(distro, configs, domain)
    assert sorted(result["topics"]) == sorted(TOPICS)  # what the writer process says it writes
    padding = "00" * (GID_BYTES[distro] - 16)
    for config in configs:
        seen = result["readers"][config]
        assert "error" not in seen, (config, seen)
        ours = [p for p in seen["publications"] if p["topic"] in [*result["topics"], "ros_discovery_info"]]
        participants = {p["participant_key"] for p in ours}
        assert len(participants) == 1, (
            f"{config}: {len(ours)} of our writers matched, by {len(participants)} participants"
        )
        (participant,) = participants
        by_topic = {p["topic"]: p for p in ours}
        assert sorted(by_topic) == sorted([*result["topics"], "ros_discovery_info"]), config  # every topic matched
        assert seen["participants"][participant] == "enclave=/;", config
        for topic, writer in by_topic.items():
            kind = expected_kind(topic, distro)
            assert writer["type"] == kind.__idl_typename__.replace(".", "::"), (config, writer)
            assert writer["user_data"] == f"typehash={type_hash(kind)};", (config, writer)
        qos = " ".join(by_topic["ros_discovery_info"]["qos"])
        for policy in ("Reliability.Reliable", "Durability.TransientLocal", "History.KeepLast(depth=1)"):
            assert policy in qos, (config, qos)
        latest = [s for s in seen["discovery"] if s["gid"][:32] == participant][-1]
        assert latest["gid"] == participant + padding, (config, latest)
        (node,) = latest["nodes"]
        assert (node["namespace"], node["name"], node["readers"]) == (NAMESPACE, NODE, []), (config, node)
        writers = {p["key"] + padding for p in ours if p["topic"] != "ros_discovery_info"}
        assert sorted(node["writers"]) == sorted(writers), (config, node)
        assert seen["tf_static"][-1] == [["link1", "camera_0"], ["link1", "camera_1"]], config
        print(
            f"{config} ({distro}): {len(by_topic)} writers matched, node {node['namespace']}/{node['name']} "
            f"with {len(node['writers'])} writer GIDs of {GID_BYTES[distro]} bytes"
        )
    group_ports = set(result["multicast_ports"])
    for address, port in result["writer_sockets"]:  # loopback, or the group on the multicast ports
        assert address == "127.0.0.1" or (address == MULTICAST_GROUP and port in group_ports), result["writer_sockets"]
    if "humble-localhost" in configs:  # this reader discovers by multicast (random unicast ports) ...
        reader_ports = {port for _, port in result["readers"]["humble-localhost"]["own_sockets"]}
        assert min(group_ports) in reader_ports, result["readers"]["humble-localhost"]["own_sockets"]
        muted = {port for _, port in result["readers"]["humble-localhost-no-multicast"]["own_sockets"]}
        assert not muted & group_ports  # ... and this one without
    if network_namespace():  # the group is joined on loopback only (the namespace's own table)
        assert [d for d, groups in result["igmp"].items() if MULTICAST_GROUP in groups] == ["lo"], result["igmp"]
