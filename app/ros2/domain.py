"""A DDS domain as ROS 2 sees it: the Cyclone DDS configuration (loopback only unless told), the
participant, and the QoS of ROS 2's conventions.

Security like the Zenoh path (docs/integrations/ros2.md): by default the domain lives on this host's
loopback only, `LOOPBACK_CONFIG`: Cyclone's `NetworkInterface` 127.0.0.1 (and its sockets bound
to 127.0.0.1, which Cyclone's configuration cannot say: `loopback_bind`), discovery both ways a
ROS 2 node on this host may look for it: by unicast to 127.0.0.1's participant ports
(`ParticipantIndex auto`: each participant on the host takes the next index, so the others find
it without multicast; what Jazzy's `ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST` does, and Humble's
`ROS_LOCALHOST_ONLY=1` where the loopback interface has no multicast), and by multicast on the
loopback interface only (`AllowMulticast spdp`: participant announcements, not data; what
Humble's `ROS_LOCALHOST_ONLY=1` does where loopback multicast works: it listens on the group, its
unicast ports random). Its multicast sockets are bound to the group, joined on loopback only.
Beyond loopback only with a Cyclone configuration file (`--ros2-config`), which must enable DDS
Security (a `<Security>` section: SROS2's certificates and governance, what ROS 2 calls SROS2)
unless `--ros2-insecure-network` says the network is trusted; a file that cannot be read or
parsed is one line (`check_config`).

The participant is a ROS 2 node (`participant`, `discovery`): USER_DATA `enclave=/;`, its node
on `ros_discovery_info`, and each writer made by `Ros2Domain.writer` listed as the node's, with
its type hash in USER_DATA.

QoS (`Qos`): the sensor-data profile of ROS 2 (`rmw_qos_profile_sensor_data`: best effort, keep
last 5, volatile) for markers and dots; tf2's for `/tf` (reliable, keep last 100) and
`/tf_static` (reliable, transient local, keep last 1: a late subscriber gets the cameras);
ROS 2's default (reliable, keep last 10) for throws. Every writer asks for XCDR1 (ROS 2's CDR).
"""

from __future__ import annotations

import os
import xml.etree.ElementTree as ET
from contextlib import nullcontext
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from wiithrow.app.errors import AppError
from wiithrow.app.ros2.participant import Ros2Node

#: ROS 2's domain ids: 0-101 and 215-232 fit the default port mapping on Linux; 0-232 is what DDS allows.
MAX_DOMAIN_ID = 232

LOOPBACK_CONFIG = """<CycloneDDS xmlns="https://cdds.io/config">
  <Domain id="any">
    <General>
      <Interfaces><NetworkInterface address="127.0.0.1" multicast="true"/></Interfaces>
      <AllowMulticast>spdp</AllowMulticast>
    </General>
    <Discovery>
      <ParticipantIndex>auto</ParticipantIndex>
      <MaxAutoParticipantIndex>32</MaxAutoParticipantIndex>
      <Peers><Peer address="127.0.0.1"/></Peers>
    </Discovery>
  </Domain>
</CycloneDDS>"""


def default_domain_id() -> int:
    """ROS_DOMAIN_ID if set (and valid), else 0, as ROS 2 does."""
    text = os.environ.get("ROS_DOMAIN_ID", "").strip()
    if not text:
        return 0
    return domain_id(text, "ROS_DOMAIN_ID")


def domain_id(text: str, what: str = "--ros2-domain") -> int:
    """A DDS domain id (0-232), else AppError in one line."""
    try:
        value = int(text)
    except ValueError:
        raise AppError(f"{what} is a DDS domain id, an integer 0-{MAX_DOMAIN_ID}, not {text!r}") from None
    if not 0 <= value <= MAX_DOMAIN_ID:
        raise AppError(f"{what} is a DDS domain id, 0-{MAX_DOMAIN_ID}, not {value}")
    return value


def check_config(path: str | os.PathLike[str], *, insecure_network: bool) -> str:
    """The text of a Cyclone configuration file that may be used: readable XML, and with DDS
    Security unless `insecure_network`; else AppError in one line."""
    try:
        text = Path(path).read_text()
        root = ET.fromstring(text)
    except OSError as exc:
        raise AppError(f"--ros2-config {path}: {exc.strerror or exc}") from None
    except ET.ParseError as exc:
        raise AppError(f"--ros2-config {path} is not XML: {exc}") from None
    if not root.tag.endswith("CycloneDDS"):
        raise AppError(f"--ros2-config {path} is not a Cyclone DDS configuration (its root is <{root.tag}>)")
    secured = any(element.tag.split("}")[-1] == "Security" for element in root.iter())
    if not secured and not insecure_network:
        raise AppError(
            f"--ros2-config {path} has no <Security> section (DDS Security, SROS2's certificates): anyone on the "
            "network it opens could read the rig and publish as it; add one, or --ros2-insecure-network on a "
            "trusted network"
        )
    return text


class Qos:
    """The QoS of ROS 2's conventions (module docstring), built when first asked for."""

    @staticmethod
    def sensor_data() -> Any:
        from cyclonedds.core import Policy
        from cyclonedds.core import Qos as DdsQos

        return DdsQos(
            Policy.Reliability.BestEffort,
            Policy.History.KeepLast(5),
            Policy.Durability.Volatile,
            Policy.DataRepresentation(use_cdrv0_representation=True),
        )

    @staticmethod
    def tf() -> Any:
        from cyclonedds.core import Policy
        from cyclonedds.core import Qos as DdsQos
        from cyclonedds.util import duration

        return DdsQos(
            Policy.Reliability.Reliable(duration(milliseconds=100)),
            Policy.History.KeepLast(100),
            Policy.Durability.Volatile,
            Policy.DataRepresentation(use_cdrv0_representation=True),
        )

    @staticmethod
    def tf_static() -> Any:
        from cyclonedds.core import Policy
        from cyclonedds.core import Qos as DdsQos
        from cyclonedds.util import duration

        return DdsQos(
            Policy.Reliability.Reliable(duration(milliseconds=100)),
            Policy.History.KeepLast(1),
            Policy.Durability.TransientLocal,
            Policy.DataRepresentation(use_cdrv0_representation=True),
        )

    @staticmethod
    def default() -> Any:
        from cyclonedds.core import Policy
        from cyclonedds.core import Qos as DdsQos
        from cyclonedds.util import duration

        return DdsQos(
            Policy.Reliability.Reliable(duration(milliseconds=100)),
            Policy.History.KeepLast(10),
            Policy.Durability.Volatile,
            Policy.DataRepresentation(use_cdrv0_representation=True),
        )


@dataclass
class Ros2Domain:
    """A participant in DDS domain `domain_id` configured by `config` (XML text; default: loopback
    only, its sockets bound to 127.0.0.1 or its multicast group: `loopback_bind`), announced as
    ROS 2 node `node` (`graph`). A domain that cannot open is AppError in one line: whose ports
    are taken and where to move (`ports.taken_ports_message`), else what Cyclone said (its own
    lines on stderr are captured: they are the detail, not printed)."""

    domain_id: int = 0
    config: str = LOOPBACK_CONFIG
    node: Ros2Node = field(default_factory=Ros2Node)

    def __post_init__(self) -> None:
        from cyclonedds.domain import Domain, DomainParticipant

        from wiithrow.app.ros2.discovery import NodeGraph
        from wiithrow.app.ros2.loopback_bind import LoopbackBindError, cyclone_library, loopback_binds
        from wiithrow.app.ros2.participant import participant_qos
        from wiithrow.app.ros2.ports import multicast_ports, taken_ports_message
        from wiithrow.native_stderr import captured_stderr

        try:
            # the loopback configuration's sockets bind to 127.0.0.1 or its group (Cyclone binds 0.0.0.0 otherwise)
            loopback = self.config == LOOPBACK_CONFIG
            binds = loopback_binds(cyclone_library(), multicast_ports(self.domain_id)) if loopback else nullcontext()
            with captured_stderr() as said, binds:
                self._domain = Domain(self.domain_id, self.config)  # kept: the participant lives in it
                self.participant = DomainParticipant(self.domain_id, qos=participant_qos(self.node))
            self.graph = NodeGraph(self.participant, self.node)
        except LoopbackBindError as exc:
            raise AppError(
                f"cannot keep DDS on loopback ({exc}): its sockets would listen on every interface; "
                "--ros2-config FILE.xml opens it knowingly"
            ) from None
        except Exception as exc:
            detail = taken_ports_message(self.domain_id) or "; ".join([*said.lines, str(exc)])
            raise AppError(f"cannot open DDS domain {self.domain_id}: {detail}") from None
        said.replay()

    def writer(self, topic: str, kind: type, qos: Any) -> Any:
        """A DataWriter of message type `kind` (a `messages` class) on DDS topic `topic` with `qos`,
        its type hash in USER_DATA, listed as the node's writer on `ros_discovery_info`."""
        from cyclonedds.pub import DataWriter
        from cyclonedds.topic import Topic

        from wiithrow.app.ros2.participant import writer_qos

        writer: DataWriter[Any] = DataWriter(
            self.participant, Topic(self.participant, topic, kind, qos=qos), qos=writer_qos(qos, kind)
        )
        self.graph.add_writer(writer)
        return writer

    def close(self) -> None:
        """Delete the participant (and its topics, writers and readers) and the domain."""
        for entity in (self.participant, self._domain):
            try:
                entity.__del__()
            except Exception:  # already deleted
                pass


def topic_name(namespace: str, name: str) -> str:
    """The DDS topic of ROS 2 topic `name` under `namespace`: 'rt' + the fully qualified name
    (an absolute `name`, '/tf', ignores the namespace, as in ROS 2)."""
    full = name if name.startswith("/") else f"{namespace.rstrip('/')}/{name}"
    return "rt" + ("/" + full.lstrip("/"))


def ros_namespace(text: str) -> str:
    """A ROS 2 namespace: '/' then names of letters, digits and '_' separated by '/' (not starting
    with a digit); '' is the root. AppError in one line otherwise."""
    import re

    clean = "/" + text.strip("/") if text.strip("/") else ""
    if clean and not re.fullmatch(r"(/[A-Za-z_][A-Za-z0-9_]*)+", clean):
        raise AppError(
            f"--ros2-namespace is a ROS 2 namespace (names of letters, digits and '_' separated by '/'), not {text!r}"
        )
    return clean


def ros_name(text: str) -> str:
    """`text` as one ROS 2 name token (other characters become '_'; a leading digit gets a '_')."""
    import re

    name = re.sub(r"[^A-Za-z0-9_]", "_", text) or "_"
    return "_" + name if name[0].isdigit() else name
