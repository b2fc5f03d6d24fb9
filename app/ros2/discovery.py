"""The node in ROS 2's graph: `ros_discovery_info`, what every rmw_cyclonedds participant publishes
about its nodes (`NodeGraph`).

ROS 2 (rmw_dds_common's graph cache) learns a participant's nodes, and which node owns each
writer, from one sample per participant on the DDS topic `ros_discovery_info` (no `rt` prefix),
type `rmw_dds_common::msg::dds_::ParticipantEntitiesInfo_`:

    ParticipantEntitiesInfo: Gid gid, NodeEntitiesInfo[] node_entities_info_seq
    NodeEntitiesInfo: string<=256 node_namespace, string<=256 node_name,
                      Gid[] reader_gid_seq, Gid[] writer_gid_seq
    Gid: char[N] data  (N = 24 up to Humble, 16 from Iron: `participant.GID_BYTES`)

An entity's GID is its DDS GUID (16 bytes: prefix and entity id, as on the wire), padded with
zeros to N bytes (rmw_cyclonedds' `convert_guid_to_gid`); `gid` is the participant's, and the
node's `writer_gid_seq` lists the GIDs of the writers `add_writer` was given, which ROS 2 then
shows as the node's publishers (`ros2 topic info -v`). The graph cache keys participants by GID,
so these must equal what it derives from the DCPSParticipant and DCPSPublication builtin topics.

The writer's QoS is rmw_cyclonedds' for it: reliable, keep last 1, transient local (with the
durability service keeping the last 1: a node that starts later gets the current sample), no
autodispose, XCDR1, and its type hash in USER_DATA (`participant.writer_qos`). The sample is
written again at every change (rmw_cyclonedds does so at every endpoint a node creates).
"""

# (no `from __future__ import annotations`: cyclonedds reads the annotations as objects)
import threading
import uuid
from dataclasses import dataclass, field
from typing import Any

from cyclonedds.idl import IdlStruct, types

from wiithrow.app.ros2.participant import Ros2Node, writer_qos

DISCOVERY_TOPIC = "ros_discovery_info"


def _name(message: str) -> str:
    return f"rmw_dds_common.msg.dds_.{message}_"


# -- from Iron on (16-byte GIDs); bounded_str[256]: rmw_dds_common's bound on the names


@dataclass
class Gid(IdlStruct, typename=_name("Gid")):
    data: types.array[types.uint8, 16] = field(default_factory=lambda: [0] * 16)


@dataclass
class NodeEntitiesInfo(IdlStruct, typename=_name("NodeEntitiesInfo")):
    node_namespace: types.bounded_str[256] = ""
    node_name: types.bounded_str[256] = ""
    reader_gid_seq: types.sequence[Gid] = field(default_factory=list)
    writer_gid_seq: types.sequence[Gid] = field(default_factory=list)


@dataclass
class ParticipantEntitiesInfo(IdlStruct, typename=_name("ParticipantEntitiesInfo")):
    gid: Gid = field(default_factory=Gid)
    node_entities_info_seq: types.sequence[NodeEntitiesInfo] = field(default_factory=list)


# -- up to Humble (24-byte GIDs): the same DDS names, another layout


@dataclass
class HumbleGid(IdlStruct, typename=_name("Gid")):
    data: types.array[types.uint8, 24] = field(default_factory=lambda: [0] * 24)


@dataclass
class HumbleNodeEntitiesInfo(IdlStruct, typename=_name("NodeEntitiesInfo")):
    node_namespace: types.bounded_str[256] = ""
    node_name: types.bounded_str[256] = ""
    reader_gid_seq: types.sequence[HumbleGid] = field(default_factory=list)
    writer_gid_seq: types.sequence[HumbleGid] = field(default_factory=list)


@dataclass
class HumbleParticipantEntitiesInfo(IdlStruct, typename=_name("ParticipantEntitiesInfo")):
    gid: HumbleGid = field(default_factory=HumbleGid)
    node_entities_info_seq: types.sequence[HumbleNodeEntitiesInfo] = field(default_factory=list)


#: (Gid, NodeEntitiesInfo, ParticipantEntitiesInfo) of each graph format (`participant.DISTROS`).
FORMS: dict[str, tuple[type, type, type]] = {
    "humble": (HumbleGid, HumbleNodeEntitiesInfo, HumbleParticipantEntitiesInfo),
    "jazzy": (Gid, NodeEntitiesInfo, ParticipantEntitiesInfo),
}


def gid(guid: uuid.UUID, size: int) -> bytes:
    """The GID of the entity whose DDS GUID is `guid`: its 16 bytes, zero-padded to `size`."""
    return guid.bytes + bytes(size - len(guid.bytes))


def discovery_qos() -> Any:
    """rmw_cyclonedds' QoS of `ros_discovery_info` (module docstring)."""
    from cyclonedds.core import Policy, Qos
    from cyclonedds.util import duration

    unlimited = -1
    return Qos(
        Policy.Reliability.Reliable(duration(infinite=True)),
        Policy.History.KeepLast(1),
        Policy.Durability.TransientLocal,
        Policy.DurabilityService(0, Policy.History.KeepLast(1), unlimited, unlimited, unlimited),
        Policy.WriterDataLifecycle(autodispose=False),
        Policy.DataRepresentation(use_cdrv0_representation=True),
    )


class NodeGraph:
    """`node` in ROS 2's graph, for the participant `participant`: its `ros_discovery_info` writer,
    written at once (the node, no writers yet) and again at each `add_writer`."""

    def __init__(self, participant: Any, node: Ros2Node) -> None:
        from cyclonedds.pub import DataWriter
        from cyclonedds.topic import Topic

        self.node = node
        self._gid_type, self._node_type, self._info_type = FORMS[node.distro]
        qos = discovery_qos()
        topic: Topic[Any] = Topic(participant, DISCOVERY_TOPIC, self._info_type, qos=qos)
        self._writer = DataWriter(participant, topic, qos=writer_qos(qos, self._info_type))
        self.participant_gid = gid(participant.guid, node.gid_bytes)
        self.writer_gids: list[bytes] = []
        self._lock = threading.Lock()  # one change and its sample at a time
        self.publish()

    def add_writer(self, writer: Any) -> None:
        """List `writer` (a DataWriter of the participant) as the node's, and say so."""
        with self._lock:
            self.writer_gids.append(gid(writer.guid, self.node.gid_bytes))
            self._write()

    def publish(self) -> None:
        """Write the node's current entry (a late reader gets the last: transient local)."""
        with self._lock:
            self._write()

    def message(self) -> Any:
        """The ParticipantEntitiesInfo sample (of the node's graph format) that is written."""
        return self._info_type(
            gid=self._gid_type(data=list(self.participant_gid)),
            node_entities_info_seq=[
                self._node_type(
                    node_namespace=self.node.graph_namespace,
                    node_name=self.node.name,
                    reader_gid_seq=[],
                    writer_gid_seq=[self._gid_type(data=list(g)) for g in self.writer_gids],
                )
            ],
        )

    def _write(self) -> None:
        self._writer.write(self.message())
