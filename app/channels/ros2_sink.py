"""The ROS 2 sink: `Ros2Publisher` writes the channels' ROS 2 forms as DDS topics; `Ros2ProcessPublisher`,
what `--ros2` runs, is it in a writer process (`sink_process`).

Every channel with a ROS 2 form (`registry`) is a DDS topic as ROS 2 names them (`rt/<namespace>/
<name>`, an absolute name ignoring the namespace), typed as ROS 2's message
(`wiithrow.app.ros2.messages.BY_TYPE`), with the registry's QoS; each message is the channel's
JSON message encoded as that type's CDR (`ros2_messages`, packed by hand: `cdr`) and handed to the
DDS writer as bytes (`_write_cdr`). Under the namespace (default `/wiithrow`): `markers`
(mocap4r2 Markers), `markers/visualization` (MarkerArray, for RViz), `cameras/<name>/dots`
(PointCloud), `joint_states`, `arm/trajectory`, `throws` (String: the throw's document as JSON),
`robot_description` (String: the URDF, transient local); and `/tf` (base -> link1 of a session's
arm), `/tf_static` (link1 -> each camera, transient local: a late subscriber gets the cameras).

Every header's `stamp` is the Unix time of what it carries (a frame's time on the rig's clock,
mapped once: `wall_time`), what tf looks transforms up by and what Foxglove's timeline shows for
the same frame. A message is encoded only for a topic with a matched reader or a transient-local
one (a volatile sample with no reader reaches no one, now or later: with RViz closed, no
MarkerArray is packed); `wants` tells the tracking process what not to hand over at all.

The writer process: the tracking process packs each frame (`SinkProcess`, gated by what the
child's readers want: `WANTS`), the child (`ros2_writer`) owns the DDS domain and a
`Ros2Publisher`; a session's messages (its URDF, trajectories, throws) come as JSON lines. Every
writer is made by the domain (`Ros2Domain.writer`) when the publisher starts: the node's
`ros_discovery_info` lists it, its USER_DATA carries its type's hash. The child's participant is
the ROS 2 node the caller names (`--ros2-node`, `--ros2-distro`)."""

from __future__ import annotations

import sys
import time
from collections.abc import Callable, Sequence
from typing import Any

from wiithrow.app.channels import registry as r
from wiithrow.app.channels import ros2_messages
from wiithrow.app.channels.cdr import padded
from wiithrow.app.channels.sink_process import WANT_ARM, WANT_MARKERS, SinkProcess, want_dots
from wiithrow.app.ros2.domain import LOOPBACK_CONFIG, Ros2Domain, ros_name, topic_name
from wiithrow.app.ros2.participant import Ros2Node
from wiithrow.clock import Clock

DEFAULT_NAMESPACE = "/wiithrow"
#: How long the best-effort writers linger before the domain closes: nothing acknowledges them,
#: and deleting a writer drops what it has not sent yet.
LINGER_S = 0.3
#: The reliable writers' blocking time when a reader's history is full (DDS's max_blocking_time).
RELIABLE_BLOCKING_MS = 100


def dds_qos(qos: r.Qos) -> Any:
    """The registry's QoS as Cyclone's (XCDR1: ROS 2's CDR)."""
    from cyclonedds.core import Policy
    from cyclonedds.core import Qos as DdsQos
    from cyclonedds.util import duration

    return DdsQos(
        Policy.Reliability.Reliable(duration(milliseconds=RELIABLE_BLOCKING_MS))
        if qos.reliable
        else Policy.Reliability.BestEffort,
        Policy.History.KeepLast(qos.depth),
        Policy.Durability.TransientLocal if qos.transient_local else Policy.Durability.Volatile,
        Policy.DataRepresentation(use_cdrv0_representation=True),
    )


def _write_cdr(writer: Any, data: bytes) -> None:
    """Write one sample already in CDR (`cdr`) with `writer`: what `DataWriter.write` does after
    its own serialisation (cyclonedds 11: pad to whole words, `ddspy_write`), so the bytes on the
    wire are the ones cyclonedds would send."""
    from cyclonedds._clayer import ddspy_write  # type: ignore[import-not-found]  # the C layer: no stubs
    from cyclonedds.core import DDSException

    ret = ddspy_write(writer._ref, padded(data))
    if ret < 0:
        raise DDSException(ret, f"Occurred while writing sample in {writer!r}")


def _has_reader(writer: Any) -> bool:
    """Whether `writer` has a matched reader now (under a microsecond: a C call)."""
    return bool(writer.get_matched_subscriptions())


def dds_topics(namespace: str, camera_names: Sequence[str]) -> list[tuple[str, r.Ros2Form, str]]:
    """Every DDS topic the publisher writes for a rig of `camera_names` under `namespace`: (the
    channel's recording topic, its ROS 2 form, the DDS topic name), in the registry's order."""
    out = []
    for channel in r.CHANNELS:
        cameras = range(len(camera_names)) if channel.per_camera else [None]
        for form in channel.ros2:
            for c in cameras:
                name = form.topic if c is None else form.topic.format(name=ros_name(camera_names[c]))
                out.append((channel.topic_of(c), form, topic_name(namespace, name)))
    return out


class Ros2Publisher:
    """The channels' ROS 2 forms on `domain` (open), for a rig of `camera_names` (module docstring)."""

    def __init__(self, domain: Ros2Domain, camera_names: Sequence[str], *, namespace: str = DEFAULT_NAMESPACE) -> None:
        from wiithrow.app.ros2.messages import BY_TYPE

        self.domain = domain
        self.namespace = namespace
        self.camera_names = list(camera_names)
        #: channel topic -> [(ROS 2 form, DDS topic name, writer)]
        self.routes: dict[str, list[tuple[r.Ros2Form, str, Any]]] = {}
        for topic, form, dds_name in dds_topics(namespace, self.camera_names):
            # the domain's writer: listed as the node's on ros_discovery_info, its type hash in USER_DATA
            writer = domain.writer(dds_name, BY_TYPE[form.type], dds_qos(form.qos))
            self.routes.setdefault(topic, []).append((form, dds_name, writer))
        self.samples_written = 0  # samples handed to DDS
        self.samples_unread = 0  # samples not encoded: their topic had no reader

    def writers(self) -> list[Any]:
        """Every DDS writer of the publisher (what a node's discovery data lists)."""
        return [writer for routes in self.routes.values() for _, _, writer in routes]

    def dds_topic(self, topic: str, ros2_type: str | None = None) -> str:
        """The DDS topic of a channel's topic (its first ROS 2 form, or the one of `ros2_type`)."""
        return next(name for form, name, _ in self.routes[topic] if ros2_type in (None, form.type))

    def wanted(self, topic: str) -> bool:
        """Whether a message of `topic` would be written now (a reader, or transient local)."""
        return any(form.qos.transient_local or _has_reader(w) for form, _, w in self.routes.get(topic, ()))

    def write(self, topic: str, stamp_ns: int, message: dict[str, Any], seq: int = 0) -> None:
        """`message` (the channel's JSON message) as each ROS 2 form of `topic` that is wanted."""
        for form, _, writer in self.routes.get(topic, ()):
            if not (form.qos.transient_local or _has_reader(writer)):
                self.samples_unread += 1
                continue
            _write_cdr(writer, ros2_messages.encode(form.type, message, stamp_ns, seq))
            self.samples_written += 1

    def wants(self) -> int:
        """What the tracking process should hand over now (`sink_process.WANTS`)."""
        wants = WANT_MARKERS if self.wanted(r.MARKERS.topic) else 0
        if self.wanted(r.TF.topic) or self.wanted(r.JOINTS.topic):
            wants |= WANT_ARM
        for c in range(len(self.camera_names)):
            if self.wanted(r.DOTS.topic_of(c)):
                wants |= want_dots(c)
        return wants

    def subscribers(self) -> int:
        """How many readers of `markers` are matched."""
        return len(self.routes[r.MARKERS.topic][0][2].get_matched_subscriptions())

    def drain(self, timeout_s: float = 1.0) -> None:
        """Before the domain closes: wait for the reliable topics' acknowledgements, and `LINGER_S`
        for the best-effort ones."""
        from cyclonedds.util import duration

        for routes in self.routes.values():
            for form, _, writer in routes:
                if form.qos.reliable:
                    try:
                        writer.wait_for_acks(duration(seconds=timeout_s))
                    except Exception:  # no reader, or the domain is gone: nothing to wait for
                        pass
        time.sleep(LINGER_S)


#: The child's figures in the ring's header (`FrameRing.report`; `WANTS` is the sink process's).
SUBSCRIBERS, SAMPLES_WRITTEN, SAMPLES_UNREAD = 3, 4, 5
#: Records of the ring: ~8 s of a 4-camera rig at 100 Hz.
RING_SLOTS = 4096


def carries(topic: str) -> bool:
    """The session messages ROS 2 carries: those of a channel with a ROS 2 form."""
    channel = r.channel_of(topic)
    return channel is not None and bool(channel.ros2)


class Ros2ProcessPublisher(SinkProcess):
    """The `Ros2Publisher` of `domain_id` / `config` in a writer process (module docstring);
    `joint_names`: a session's arm's, for `joint_states`. The child's participant is ROS 2 node
    `node` (default: `participant.DEFAULT_NODE_NAME` in `namespace`)."""

    def __init__(
        self,
        domain_id: int,
        camera_names: Sequence[str],
        frame_name: str,
        *,
        clock: Clock,
        config: str = LOOPBACK_CONFIG,
        namespace: str = DEFAULT_NAMESPACE,
        joint_names: Sequence[str] = (),
        on_failure: Callable[[str], None] | None = None,
        node: Ros2Node | None = None,
    ) -> None:
        self.domain_id = domain_id
        #: the DDS topics the child writes (`dds_topics`)
        self.topics = [name for _, _, name in dds_topics(namespace, camera_names)]
        self.node = Ros2Node(namespace=namespace) if node is None else node  # its participant's ROS 2 node
        self.namespace = namespace
        self.frame_name = frame_name
        super().__init__(
            "ROS 2",
            "wiithrow.app.channels.ros2_writer",
            {
                "domain_id": domain_id,
                "config": config,
                "frame_name": frame_name,
                "namespace": namespace,
                "joint_names": list(joint_names),
                "node": {"name": self.node.name, "namespace": self.node.namespace, "distro": self.node.distro},
            },
            clock=clock,
            cameras=camera_names,
            slots=RING_SLOTS,
            gated=True,
            carries=carries,
            on_failure=on_failure,
        )

    @property
    def samples_written(self) -> int:
        return self.figure(SAMPLES_WRITTEN)

    @property
    def samples_unread(self) -> int:
        return self.figure(SAMPLES_UNREAD)

    def subscribers(self) -> int:
        """How many readers of `markers` the child has matched (told every ~50 ms)."""
        return self.figure(SUBSCRIBERS)

    def wait_for_subscribers(self, timeout_s: float, count: int = 1) -> bool:
        end = time.monotonic() + timeout_s
        while self.subscribers() < count:
            if time.monotonic() >= end or not self.process.alive():
                return False
            time.sleep(0.01)
        return True

    def announcement(self) -> str:
        return (
            f"ROS 2 topics under {self.namespace or '/'} (and /tf, /tf_static) on DDS domain {self.domain_id}, "
            f"node {self.node.namespace}/{self.node.name} ({self.node.distro}'s graph; a writer process, pid "
            f"{self.process.pid})"
        )

    def summary(self) -> str:
        return (
            f"published {self.markers_sent} marker frames, {sum(self.dots_sent)} camera frames, {self.arm_sent} arm "
            f"samples (/tf, joint_states) as ROS 2 topics under {self.namespace or '/'}"
            + (
                f" ({self.records_dropped} frames dropped: the writer process was behind)"
                if self.records_dropped
                else ""
            )
            + (f"; writing stopped: {self.failure}" if self.failure else "")
        )


def tell_failure(command: str) -> Callable[[str], None]:
    """What `on_failure` does on the command line: one line on stderr."""

    def tell(failure: str) -> None:
        print(f"wiithrow {command}: {failure}; tracking goes on without ROS 2", file=sys.stderr, flush=True)

    return tell
