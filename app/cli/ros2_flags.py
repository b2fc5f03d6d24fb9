"""`--ros2` on the command line: a command's rig (and session) as ROS 2 topics over DDS.

`add_ros2_arguments` gives a command `--ros2`, `--ros2-domain` (default ROS_DOMAIN_ID, else 0),
`--ros2-namespace` (default /wiithrow), `--ros2-node` (the ROS 2 node's name, default wiithrow),
`--ros2-distro` (the graph format: humble or jazzy, default by ROS_DISTRO), `--ros2-config` (a Cyclone DDS XML file: beyond loopback)
and `--ros2-insecure-network` (such a file without DDS Security); `check_ros2_arguments` refuses
the others without `--ros2`, and a config file that is unreadable or unsecured, before the
command's work starts. `Ros2Publishing` starts the `Ros2ProcessPublisher` (the DDS domain and
its writers in a writer process, fed through shared memory) and has it follow a source (each event
packed on the source's thread as it tells it); `ros2_session` publishes a running session's rig,
its arm (base -> link1 on /tf, joint_states), its URDF, trajectories and throws until closed. What
was sent goes to stderr at the end. (docs/integrations/ros2.md.)
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Callable, Sequence
from typing import TYPE_CHECKING

from wiithrow.app.cli.arguments import refuse_flags

if TYPE_CHECKING:
    from wiithrow.app.channels.ros2_sink import Ros2ProcessPublisher
    from wiithrow.app.rig.source import MarkerSource
    from wiithrow.app.ros2.participant import Ros2Node
    from wiithrow.app.session import Session
    from wiithrow.clock import Clock

ROS2_FLAGS = ("ros2_domain", "ros2_namespace", "ros2_node", "ros2_distro", "ros2_config", "ros2_insecure_network")


def add_ros2_arguments(parser: argparse.ArgumentParser) -> None:
    group = parser.add_argument_group("ROS 2 (docs/integrations/ros2.md)")
    group.add_argument(
        "--ros2",
        action="store_true",
        help="also publish the markers, /tf, each camera's dots and the throws as ROS 2 topics (DDS, this host's "
        "loopback unless --ros2-config)",
    )
    group.add_argument(
        "--ros2-domain", metavar="ID", default=None, help="DDS domain id, 0-232 (default: ROS_DOMAIN_ID, else 0)"
    )
    group.add_argument(
        "--ros2-namespace", metavar="NS", default=None, help="namespace of the topics (default: /wiithrow)"
    )
    group.add_argument(
        "--ros2-node", metavar="NAME", default=None, help="the ROS 2 node's name in the namespace (default: wiithrow)"
    )
    group.add_argument(
        "--ros2-distro",
        choices=("humble", "jazzy"),
        default=None,
        help="the ROS 2 graph's format for ros2 node list: humble (and older) or jazzy (Iron and later) "
        "(default: ROS_DISTRO's, else jazzy)",
    )
    group.add_argument(
        "--ros2-config",
        metavar="FILE.xml",
        default=None,
        help="a Cyclone DDS configuration to reach other hosts (its interfaces and peers); it must enable DDS "
        "Security (<Security>) unless --ros2-insecure-network",
    )
    group.add_argument(
        "--ros2-insecure-network",
        action="store_true",
        help="with --ros2-config: accept a configuration without DDS Security (a trusted network only)",
    )


def check_ros2_arguments(args: argparse.Namespace) -> None:
    """Refuse the ROS 2 flags without --ros2, a bad domain or namespace, an unusable config file."""
    from wiithrow.app.ros2.domain import check_config, domain_id, ros_namespace
    from wiithrow.app.ros2.participant import node_name

    if not getattr(args, "ros2", False):
        refuse_flags(args, ROS2_FLAGS, "without --ros2")
        return
    if getattr(args, "ros2_domain", None) is not None:
        domain_id(args.ros2_domain)
    if getattr(args, "ros2_namespace", None) is not None:
        ros_namespace(args.ros2_namespace)
    if getattr(args, "ros2_node", None) is not None:
        node_name(args.ros2_node)
    if args.ros2_config is None:
        refuse_flags(args, ("ros2_insecure_network",), "without --ros2-config (without one, DDS stays on loopback)")
    else:
        check_config(args.ros2_config, insecure_network=args.ros2_insecure_network)


class Ros2Publishing:
    """The rig's ROS 2 publisher, its DDS domain in a writer process (`Ros2ProcessPublisher`), on the
    rig's `clock`; `close()` ends it and says what was sent."""

    def __init__(
        self,
        args: argparse.Namespace,
        command: str,
        camera_names: Sequence[str],
        frame_name: str,
        clock: Clock,
        *,
        joint_names: Sequence[str] = (),
    ) -> None:
        from wiithrow.app.channels.ros2_sink import DEFAULT_NAMESPACE, Ros2ProcessPublisher, tell_failure
        from wiithrow.app.ros2.domain import LOOPBACK_CONFIG, check_config, default_domain_id, domain_id, ros_namespace

        self.command = command
        config = LOOPBACK_CONFIG
        if getattr(args, "ros2_config", None) is not None:
            config = check_config(args.ros2_config, insecure_network=getattr(args, "ros2_insecure_network", False))
        domain = domain_id(args.ros2_domain) if getattr(args, "ros2_domain", None) is not None else default_domain_id()
        namespace = getattr(args, "ros2_namespace", None)
        namespace = DEFAULT_NAMESPACE if namespace is None else ros_namespace(namespace)
        # the DDS domain and the writers live in a writer process: the tracking thread only hands frames over
        self.publisher: Ros2ProcessPublisher = Ros2ProcessPublisher(
            domain,
            camera_names,
            frame_name,
            clock=clock,
            config=config,
            namespace=namespace,
            joint_names=joint_names,
            on_failure=tell_failure(command),
            node=ros2_node(args, namespace),
        )
        self._stop_feed: Callable[[], None] | None = None
        print(f"wiithrow {command}: {self.publisher.announcement()}", file=sys.stderr, flush=True)

    def follow(self, source: MarkerSource) -> None:
        """Publish what `source` tracks and reads from now on (and its calibration on /tf_static),
        packed on its own thread as it tells it."""
        self.publisher.follow(source)

    def watch(self, session: Session) -> None:
        """Publish `session`'s rig, its arm (/tf, joint_states), its URDF, trajectories and throws, until `close`."""
        from wiithrow.app.recording.session_feed import follow_session

        self._stop_feed = follow_session(self.publisher, session)

    def close(self) -> None:
        if self._stop_feed is not None:
            self._stop_feed()
        self.publisher.close()
        print(f"wiithrow {self.command}: {self.publisher.summary()}", file=sys.stderr, flush=True)


def ros2_node(args: argparse.Namespace, namespace: str) -> Ros2Node:
    """The ROS 2 node `--ros2-node` and `--ros2-distro` name, in the topics' `namespace`."""
    from wiithrow.app.ros2.participant import DEFAULT_NODE_NAME, Ros2Node, default_distro, node_name

    name = getattr(args, "ros2_node", None)
    distro = getattr(args, "ros2_distro", None)
    return Ros2Node(
        name=DEFAULT_NODE_NAME if name is None else node_name(name),
        namespace=namespace,
        distro=default_distro() if distro is None else distro,
    )


def ros2_session(args: argparse.Namespace, command: str, session: Session) -> Ros2Publishing | None:
    """With --ros2: publish `session` until the result is closed (flags checked: `check_ros2_arguments`)."""
    if not getattr(args, "ros2", False):
        return None
    world = session.world
    publishing = Ros2Publishing(
        args, command, world.rig.camera_names, "link1", world.clock, joint_names=world.arm_model.joint_names
    )
    publishing.watch(session)
    return publishing
