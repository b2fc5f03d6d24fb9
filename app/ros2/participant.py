"""What makes the DDS participant a ROS 2 node to ROS 2's tools: who the node is (`Ros2Node`: its
name, namespace, enclave and the ROS 2 distribution whose graph format it speaks) and the USER_DATA
rmw_cyclonedds puts on its entities.

- The participant's USER_DATA is `enclave=<enclave>;` (`participant_qos`). rmw_cyclonedds (Humble
  and later) adds a remote participant to its graph only when that key is there; the default
  enclave is '/', rcl's.
- Each writer's USER_DATA is `typehash=RIHS01_<hex>;` (`writer_qos`): its message type's hash
  (`type_hash`), which Iron and later read into `ros2 topic info -v`. Humble reads no endpoint
  USER_DATA, so the same writers serve both.
- The graph message on `ros_discovery_info` (`discovery`) differs between distributions: a GID is
  24 bytes up to Humble and 16 from Iron (`rmw_dds_common/msg/Gid`: `char[24]`, then
  `char[16]`), and rmw_cyclonedds matches that topic by type name only, so one form is published:
  `Ros2Node.distro` (`--ros2-distro`), by default the one ROS_DISTRO names (`default_distro`).

A node name is one ROS 2 name token (letters, digits and '_', not starting with a digit, as
`rmw_validate_node_name` wants); anything else is AppError in one line (`node_name`).
"""

from __future__ import annotations

import os
import re
from dataclasses import dataclass
from typing import Any

from wiithrow.app.errors import AppError

DEFAULT_NODE_NAME = "wiithrow"
#: The node's namespace when none is given: the topics' default namespace (`publisher.DEFAULT_NAMESPACE`).
DEFAULT_NODE_NAMESPACE = "/wiithrow"
DEFAULT_ENCLAVE = "/"
#: The graph formats (`discovery`): "humble" (24-byte GIDs: Foxy, Galactic, Humble) and "jazzy"
#: (16-byte GIDs: Iron, Jazzy, Kilted, Rolling).
DISTROS = ("humble", "jazzy")
GID_BYTES = {"humble": 24, "jazzy": 16}
#: ROS_DISTRO values that speak the 24-byte form; every other one (and none) speaks "jazzy"'s.
_LEGACY_DISTROS = frozenset({"foxy", "galactic", "humble"})
#: rmw_validate_node_name's bound on a node name's length.
MAX_NODE_NAME_LENGTH = 255


@dataclass(frozen=True)
class Ros2Node:
    """The ROS 2 node the participant announces: `/namespace/name` in `ros2 node list`."""

    name: str = DEFAULT_NODE_NAME
    namespace: str = DEFAULT_NODE_NAMESPACE  # as `domain.ros_namespace` gives it: '' is the root
    distro: str = "jazzy"
    enclave: str = DEFAULT_ENCLAVE

    @property
    def graph_namespace(self) -> str:
        """The namespace as the graph carries it ('/' for the root)."""
        return self.namespace or "/"

    @property
    def gid_bytes(self) -> int:
        return GID_BYTES[self.distro]


def node_name(text: str) -> str:
    """A ROS 2 node name (module docstring), else AppError in one line."""
    if not re.fullmatch(r"[A-Za-z_][A-Za-z0-9_]*", text) or len(text) > MAX_NODE_NAME_LENGTH:
        raise AppError(
            f"--ros2-node is a ROS 2 node name (letters, digits and '_', not starting with a digit, at most "
            f"{MAX_NODE_NAME_LENGTH}), not {text!r}"
        )
    return text


def default_distro() -> str:
    """The graph format of the distribution ROS_DISTRO names: "humble" up to Humble, else "jazzy"."""
    return "humble" if os.environ.get("ROS_DISTRO", "").strip().lower() in _LEGACY_DISTROS else "jazzy"


def participant_qos(node: Ros2Node) -> Any:
    """The participant's QoS: USER_DATA `enclave=<enclave>;` (what rmw_cyclonedds sets)."""
    from cyclonedds.core import Policy, Qos

    return Qos(Policy.Userdata(f"enclave={node.enclave};".encode()))


def writer_qos(qos: Any, kind: type) -> Any:
    """`qos` with USER_DATA `typehash=RIHS01_...;` of message type `kind` (a `messages` class)."""
    from cyclonedds.core import Policy, Qos

    from wiithrow.app.ros2.type_hash import type_hash

    return Qos(Policy.Userdata(f"typehash={type_hash(kind)};".encode()), base=qos)
