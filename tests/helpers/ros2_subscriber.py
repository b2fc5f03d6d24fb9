"""A ROS 2 subscriber in its own process, its types read from the shipped IDL (`ros2_idl`).

    python -m tests.helpers.ros2_subscriber DOMAIN NAMESPACE CAMERA,... SECONDS

Reads, on DDS domain DOMAIN over this host's loopback, the topics `rt<NAMESPACE>/markers`,
`.../markers/visualization`, `.../throws`, `.../joint_states`, `.../arm/trajectory`,
`.../robot_description`, `.../cameras/<CAMERA>/dots` for each camera named, `rt/tf` and
`rt/tf_static` with ROS 2's QoS, and prints each sample as one JSON line
{"topic", "sample"} (the sample as nested dicts) for SECONDS, or until its standard input closes.
"""

from __future__ import annotations

import dataclasses
import json
import select
import sys
import time

from cyclonedds.core import Policy, Qos
from cyclonedds.domain import Domain, DomainParticipant
from cyclonedds.internal import InvalidSample
from cyclonedds.sub import DataReader
from cyclonedds.topic import Topic

from tests.helpers.ros2_idl import load_types
from wiithrow.app.ros2.domain import LOOPBACK_CONFIG


def main(domain_id: int, namespace: str, cameras: list[str], seconds: float) -> None:
    types = load_types()
    _domain = Domain(domain_id, LOOPBACK_CONFIG)
    participant = DomainParticipant(domain_id)
    best_effort = Qos(Policy.Reliability.BestEffort, Policy.History.KeepLast(1000))
    reliable = Qos(Policy.Reliability.Reliable(0), Policy.History.KeepLast(1000))
    latched = Qos(Policy.Reliability.Reliable(0), Policy.History.KeepLast(1), Policy.Durability.TransientLocal)
    wanted = {
        f"rt{namespace}/markers": ("mocap4r2_msgs::msg::dds_::Markers_", best_effort),
        f"rt{namespace}/markers/visualization": ("visualization_msgs::msg::dds_::MarkerArray_", best_effort),
        f"rt{namespace}/throws": ("std_msgs::msg::dds_::String_", reliable),
        f"rt{namespace}/joint_states": ("sensor_msgs::msg::dds_::JointState_", reliable),
        f"rt{namespace}/arm/trajectory": ("trajectory_msgs::msg::dds_::JointTrajectory_", reliable),
        f"rt{namespace}/robot_description": ("std_msgs::msg::dds_::String_", latched),
        "rt/tf": ("tf2_msgs::msg::dds_::TFMessage_", reliable),
        "rt/tf_static": ("tf2_msgs::msg::dds_::TFMessage_", latched),
    }
    for camera in cameras:
        wanted[f"rt{namespace}/cameras/{camera}/dots"] = ("sensor_msgs::msg::dds_::PointCloud_", best_effort)
    readers = {
        name: DataReader(participant, Topic(participant, name, types[kind]), qos=qos)
        for name, (kind, qos) in wanted.items()
    }
    print(json.dumps({"ready": sorted(readers)}), flush=True)
    end = time.monotonic() + seconds
    while time.monotonic() < end:
        for name, reader in readers.items():
            for sample in reader.take(N=100):
                if isinstance(sample, InvalidSample):  # a writer went away
                    continue
                print(json.dumps({"topic": name, "sample": dataclasses.asdict(sample)}), flush=True)
        if select.select([sys.stdin], [], [], 0.002)[0] and not sys.stdin.readline():
            for name, reader in readers.items():  # what came last
                for sample in reader.take(N=1000):
                    if isinstance(sample, InvalidSample):
                        continue
                    print(json.dumps({"topic": name, "sample": dataclasses.asdict(sample)}), flush=True)
            break


if __name__ == "__main__":
    main(int(sys.argv[1]), sys.argv[2], sys.argv[3].split(","), float(sys.argv[4]))
