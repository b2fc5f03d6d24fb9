"""A ROS 2 node's view of the DDS graph, in its own process, configured as rmw_cyclonedds configures
a node for the same host, its messages decoded with ROS 2's own definitions (rosbags' type stores).

    python -m tests.helpers.ros2_graph_reader DOMAIN CONFIG DISTRO TOPIC,... SECONDS

CONFIG is one of `CONFIGS`; DISTRO (humble or jazzy) chooses the `rmw_dds_common` and `tf2_msgs`
definitions (rosbags' ROS2_HUMBLE or ROS2_JAZZY store) the reader's types are built from. The
reader's participant carries `enclave=/;` as a ROS 2 node's does; it reads the DCPSParticipant and
DCPSPublication builtin topics (what rmw_cyclonedds' graph cache reads), `ros_discovery_info`
(reliable, transient local, keep all: rmw_cyclonedds' subscription) and `rt/tf_static` (tf2's
latched QoS), takes each sample's CDR bytes and decodes them with rosbags' CDR deserializer.

It stops when a participant other than its own has written every DDS topic of TOPIC,... and a
`ros_discovery_info` sample that lists its writers, and a `/tf_static` sample has come, or after
SECONDS, and prints one JSON object: `participants` (GUID hex -> USER_DATA text),
`publications` (each: key, participant_key, topic, type, user_data, and the QoS of
ros_discovery_info's writer), `discovery` (each decoded sample: gid hex, nodes with namespace,
name and writer GIDs hex), `tf_static` (each decoded sample: (parent, child) frames) and
`own_sockets` (the reader's UDP sockets: [address, port], where its Cyclone listens).
"""

from __future__ import annotations

import json
import os
import sys
import time
from typing import Any

from cyclonedds.builtin import BuiltinDataReader, BuiltinTopicDcpsParticipant, BuiltinTopicDcpsPublication
from cyclonedds.core import InstanceState, Policy, Qos, SampleState, ViewState
from cyclonedds.domain import Domain, DomainParticipant
from cyclonedds.idl import IdlStruct, make_idl_struct, types
from cyclonedds.sub import DataReader
from cyclonedds.topic import Topic
from rosbags.typesys import Stores, get_typestore
from rosbags.typesys.base import Nodetype

from tests.helpers.sockets import process_sockets

#: rmw_cyclonedds' Cyclone configuration for a node on this host only, as it builds it
#: (`check_create_domain` in rmw_cyclonedds_cpp/src/rmw_node.cpp, then $CYCLONEDDS_URI, empty here).
CONFIGS = {
    # Humble, ROS_LOCALHOST_ONLY=1 (humble branch): the loopback interface, Cyclone's defaults
    # otherwise: multicast where the interface does it (Cyclone >= 11 tries it on loopback and
    # finds it works), participant index "none" then (random unicast ports).
    "humble-localhost": (
        '<CycloneDDS><Domain><General><Interfaces><NetworkInterface address="127.0.0.1"/>'
        "</Interfaces></General></Domain></CycloneDDS>,"
    ),
    # The same as Humble's Cyclone 0.10 runs it on a loopback interface without the MULTICAST
    # flag (Linux's default): multicast off, participant index auto, 127.0.0.1 as the only peer,
    # indices 0-9 (0.10's MaxAutoParticipantIndex); Cyclone 11 does so when told the interface
    # has no multicast.
    "humble-localhost-no-multicast": (
        '<CycloneDDS><Domain><General><Interfaces><NetworkInterface address="127.0.0.1" multicast="false"/>'
        "</Interfaces></General><Discovery><MaxAutoParticipantIndex>9</MaxAutoParticipantIndex></Discovery>"
        "</Domain></CycloneDDS>,"
    ),
    # Jazzy, ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST (jazzy branch): no interface named (Cyclone
    # picks the best, a LAN interface where there is one), no multicast, localhost as the peer.
    "jazzy-localhost": (
        "<CycloneDDS><Domain><General><AllowMulticast>false</AllowMulticast></General>"
        "<Discovery><ParticipantIndex>auto</ParticipantIndex><MaxAutoParticipantIndex>32</MaxAutoParticipantIndex>"
        '<Peers><Peer address="localhost"/></Peers></Discovery></Domain></CycloneDDS>,'
    ),
}
STORES = {"humble": Stores.ROS2_HUMBLE, "jazzy": Stores.ROS2_JAZZY}
_BASE = {
    "bool": bool,
    "byte": types.byte,
    "char": types.uint8,  # rosidl: a .msg char is an IDL uint8
    "int8": types.int8,
    "uint8": types.uint8,
    "int16": types.int16,
    "uint16": types.uint16,
    "int32": types.int32,
    "uint32": types.uint32,
    "int64": types.int64,
    "uint64": types.uint64,
    "float32": types.float32,
    "float64": types.float64,
}


def dds_type(store: Any, name: str, built: dict[str, type] | None = None) -> type:
    """A cyclonedds type of ROS 2 message `name` (pkg/msg/Name) as `store` defines it, with its DDS name."""
    built = {} if built is None else built
    if name in built:
        return built[name]

    def field_type(desc: Any) -> Any:
        kind, rest = desc
        if kind == Nodetype.BASE:
            base, bound = rest
            if base == "string":
                return types.bounded_str[bound] if bound else str
            return _BASE[base]
        if kind == Nodetype.NAME:
            return dds_type(store, rest, built)
        element, count = rest
        if kind == Nodetype.ARRAY:
            return types.array[field_type(element), count]
        return types.sequence[field_type(element), count] if count else types.sequence[field_type(element)]

    package, _, message = name.split("/")
    fields = {fname: field_type(desc) for fname, desc in store.fielddefs[name][1]}
    built[name] = make_idl_struct(message, f"{package}.msg.dds_.{message}_", fields)
    return built[name]


def _user_data(qos: Qos) -> str:
    for policy in qos:
        if isinstance(policy, Policy.Userdata):
            return policy.data.decode(errors="replace")
    return ""


def raw_take(reader: DataReader[IdlStruct]) -> list[bytes]:
    """The CDR bytes (with their encapsulation header) of the valid samples `reader` holds, taken."""
    from cyclonedds._clayer import ddspy_take  # type: ignore[import-not-found]

    taken = ddspy_take(reader._ref, SampleState.Any | ViewState.Any | InstanceState.Any, 64)
    return [data for data, info in taken if info.valid_data]


def main(domain_id: int, config: str, distro: str, topics: list[str], seconds: float) -> dict[str, Any]:
    store = get_typestore(STORES[distro])
    _domain = Domain(domain_id, CONFIGS[config])
    participant = DomainParticipant(domain_id, qos=Qos(Policy.Userdata(b"enclave=/;")))
    own = participant.guid
    participants_reader = BuiltinDataReader(participant, BuiltinTopicDcpsParticipant)
    publications_reader = BuiltinDataReader(participant, BuiltinTopicDcpsPublication)
    info_name, tf_name = "rmw_dds_common/msg/ParticipantEntitiesInfo", "tf2_msgs/msg/TFMessage"
    graph_qos = Qos(Policy.Reliability.Reliable(0), Policy.History.KeepAll, Policy.Durability.TransientLocal)
    latched = Qos(Policy.Reliability.Reliable(0), Policy.History.KeepLast(1), Policy.Durability.TransientLocal)
    graph = DataReader(participant, Topic(participant, "ros_discovery_info", dds_type(store, info_name)), qos=graph_qos)
    tf_static = DataReader(participant, Topic(participant, "rt/tf_static", dds_type(store, tf_name)), qos=latched)
    found: dict[str, Any] = {"participants": {}, "publications": [], "discovery": [], "tf_static": []}
    end = time.monotonic() + seconds
    while time.monotonic() < end:
        for p in participants_reader.take(N=64):
            if getattr(p, "key", own) != own and hasattr(p, "qos"):
                found["participants"][p.key.hex] = _user_data(p.qos)
        for w in publications_reader.take(N=64):
            if hasattr(w, "topic_name") and w.participant_key != own:
                entry = {
                    "key": w.key.hex,
                    "participant_key": w.participant_key.hex,
                    "topic": w.topic_name,
                    "type": w.type_name,
                    "user_data": _user_data(w.qos),
                }
                if w.topic_name == "ros_discovery_info":
                    entry["qos"] = [repr(p) for p in w.qos]
                found["publications"].append(entry)
        for data in raw_take(graph):
            info = store.deserialize_cdr(data, info_name)
            found["discovery"].append(
                {
                    "gid": bytes(info.gid.data).hex(),
                    "nodes": [
                        {
                            "namespace": n.node_namespace,
                            "name": n.node_name,
                            "writers": [bytes(g.data).hex() for g in n.writer_gid_seq],
                            "readers": [bytes(g.data).hex() for g in n.reader_gid_seq],
                        }
                        for n in info.node_entities_info_seq
                    ],
                }
            )
        for data in raw_take(tf_static):
            message = store.deserialize_cdr(data, tf_name)
            found["tf_static"].append([[t.header.frame_id, t.child_frame_id] for t in message.transforms])
        if _complete(found, topics):
            break
        time.sleep(0.02)
    found["own_sockets"] = [list(s.local) for s in process_sockets(os.getpid()) if s.protocol == "udp"]
    return found


def _complete(found: dict[str, Any], topics: list[str]) -> bool:
    """Whether a participant has written every topic and its last graph sample lists its writers."""
    by_participant: dict[str, dict[str, str]] = {}
    for w in found["publications"]:
        by_participant.setdefault(w["participant_key"], {})[w["key"]] = w["topic"]
    for participant, writers in by_participant.items():
        if not set(topics) <= set(writers.values()):
            continue
        listed = [s for s in found["discovery"] if s["gid"].startswith(participant)]
        own = {k for k, topic in writers.items() if topic != "ros_discovery_info"}
        if listed and {g[:32] for n in listed[-1]["nodes"] for g in n["writers"]} == own and found["tf_static"]:
            return True
    return False


if __name__ == "__main__":
    result = main(int(sys.argv[1]), sys.argv[2], sys.argv[3], sys.argv[4].split(","), float(sys.argv[5]))
    print(json.dumps(result), flush=True)
